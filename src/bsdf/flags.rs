//! Lobe classification bits.

use std::ops::{BitAnd, BitOr, BitOrAssign};

/// Set of lobe kinds: a type (DIFFUSE, GLOSSY, SPECULAR = delta) and a direction (REFLECTION,
/// TRANSMISSION).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, Hash)]
pub struct BsdfFlags(pub u8);

impl BsdfFlags {
    /// No lobe.
    pub const EMPTY: BsdfFlags = BsdfFlags(0);
    /// Lambertian-like lobe.
    pub const DIFFUSE: BsdfFlags = BsdfFlags(1);
    /// Rough (non-delta, non-diffuse) lobe.
    pub const GLOSSY: BsdfFlags = BsdfFlags(2);
    /// Delta lobe (perfectly smooth).
    pub const SPECULAR: BsdfFlags = BsdfFlags(4);
    /// Scatters to the side of `wo`.
    pub const REFLECTION: BsdfFlags = BsdfFlags(8);
    /// Scatters through the surface.
    pub const TRANSMISSION: BsdfFlags = BsdfFlags(16);

    /// Whether every bit of `other` is set.
    #[inline]
    pub fn contains(self, other: BsdfFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether any bit of `other` is set.
    #[inline]
    pub fn intersects(self, other: BsdfFlags) -> bool {
        self.0 & other.0 != 0
    }

    /// Whether a delta lobe is present.
    #[inline]
    pub fn is_specular(self) -> bool {
        self.intersects(Self::SPECULAR)
    }

    /// Whether a diffuse lobe is present.
    #[inline]
    pub fn is_diffuse(self) -> bool {
        self.intersects(Self::DIFFUSE)
    }

    /// Whether a glossy lobe is present.
    #[inline]
    pub fn is_glossy(self) -> bool {
        self.intersects(Self::GLOSSY)
    }

    /// Whether a non-delta lobe is present (one that `eval`/`pdf` can see).
    #[inline]
    pub fn is_non_specular(self) -> bool {
        self.intersects(Self(Self::DIFFUSE.0 | Self::GLOSSY.0))
    }

    /// Whether a reflection lobe is present.
    #[inline]
    pub fn is_reflection(self) -> bool {
        self.intersects(Self::REFLECTION)
    }

    /// Whether a transmission lobe is present.
    #[inline]
    pub fn is_transmission(self) -> bool {
        self.intersects(Self::TRANSMISSION)
    }

    /// Whether no bit is set.
    #[inline]
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
}

impl BitOr for BsdfFlags {
    type Output = BsdfFlags;
    #[inline]
    fn bitor(self, rhs: BsdfFlags) -> BsdfFlags {
        BsdfFlags(self.0 | rhs.0)
    }
}

impl BitOrAssign for BsdfFlags {
    #[inline]
    fn bitor_assign(&mut self, rhs: BsdfFlags) {
        self.0 |= rhs.0;
    }
}

impl BitAnd for BsdfFlags {
    type Output = BsdfFlags;
    #[inline]
    fn bitand(self, rhs: BsdfFlags) -> BsdfFlags {
        BsdfFlags(self.0 & rhs.0)
    }
}
