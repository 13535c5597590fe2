//! Glossy eye samples: how the eye pass stores them (compact, [`GlossyTable`]) and the forms the
//! later stages rebuild from that: [`GlossyLobe`] to integrate against a radiance map,
//! [`GlossySample`] to evaluate per photon or per gather ray.

use crate::bsdf::{Bsdf, BsdfAt};
use crate::sampling::Frame;
use glam::Vec3;

/// A glossy eye sample's BSDF ready to evaluate: the BSDF at the fixed view direction (with its
/// per-`wo` context), and the shading frame. Built from the stored form by
/// [`GlossyTable::sample`], where light is evaluated per photon or per gather ray.
#[derive(Clone, Copy, Debug)]
pub struct GlossySample {
    pub bsdf: BsdfAt,
    pub frame: Frame,
}

impl GlossySample {
    /// BSDF value for light arriving from world direction `wi` (pointing away from the surface).
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        self.bsdf.eval(self.frame.to_local(wi))
    }

    /// [`eval`](Self::eval) with the BSDF's albedo-table lookup at `wi` memoised across calls (the
    /// same value, bit for bit; see [`crate::bsdf::AbMemo`]).
    #[inline]
    pub fn eval_memo(&self, wi: Vec3, memo: &mut crate::bsdf::AbMemo) -> Vec3 {
        self.bsdf.eval_memo(self.frame.to_local(wi), memo)
    }

    /// The lobe this sample describes, for integration against a radiance map.
    pub fn lobe(&self) -> GlossyLobe<'_> {
        GlossyLobe { bsdf: self.bsdf.bsdf(), wo: self.bsdf.wo(), frame: self.frame }
    }
}

/// What integrating a glossy eye sample against SH or histogram radiance needs: its BSDF, its view
/// direction in the shading frame, and that frame (no per-`wo` context: [`GlossyTable::lobe`]
/// costs only the frame).
#[derive(Clone, Copy, Debug)]
pub struct GlossyLobe<'a> {
    pub bsdf: &'a Bsdf,
    pub wo: Vec3,
    pub frame: Frame,
}

/// A glossy eye sample as stored (28 bytes): its BSDF (an index into [`GlossyTable`]'s distinct
/// BSDFs), its view direction in the shading frame, and the shading normal the frame is built
/// from. The expanded form ([`GlossySample`], 208 bytes) is rebuilt from these bit for bit.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub(super) struct GlossyRecord {
    pub(super) bsdf: u32,
    wo: [f32; 3],
    ns: [f32; 3],
}

const _: () = assert!(std::mem::size_of::<GlossyRecord>() == 28);

/// The glossy eye samples of a pass, compact: per sample a [`GlossyRecord`], and the BSDFs they
/// share (a sample on the same material as the one before it shares its BSDF: an untextured
/// material is stored about once per image row and material). At 500² × 4 spp on a glossy scene
/// the expanded samples took 193 MB, whose writing was a fifth of the eye pass.
#[derive(Clone, Debug, Default)]
pub struct GlossyTable {
    // (the eye pass appends its rows' tables to these directly)
    pub(super) records: Vec<GlossyRecord>,
    pub(super) bsdfs: Vec<Bsdf>,
}

impl GlossyTable {
    /// The table of expanded samples (as [`sample`](Self::sample) gives them back).
    pub fn from_samples(samples: impl IntoIterator<Item = GlossySample>) -> GlossyTable {
        let mut t = GlossyTable::default();
        for g in samples {
            t.push(g.bsdf.bsdf(), g.bsdf.wo(), g.frame.n);
        }
        t
    }

    /// Append a sample of BSDF `bsdf` seen from `wo` (in the frame of shading normal `ns`); its
    /// index.
    pub fn push(&mut self, bsdf: &Bsdf, wo: Vec3, ns: Vec3) -> u32 {
        if self.bsdfs.last() != Some(bsdf) {
            self.bsdfs.push(*bsdf);
        }
        self.records.push(GlossyRecord { bsdf: (self.bsdfs.len() - 1) as u32, wo: wo.to_array(), ns: ns.to_array() });
        (self.records.len() - 1) as u32
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    pub(super) fn clear(&mut self) {
        self.records.clear();
        self.bsdfs.clear();
    }

    /// The BSDF of sample `i`.
    #[inline]
    pub fn bsdf(&self, i: usize) -> &Bsdf {
        &self.bsdfs[self.records[i].bsdf as usize]
    }

    /// Sample `i` for integration against a radiance map.
    #[inline]
    pub fn lobe(&self, i: usize) -> GlossyLobe<'_> {
        let r = &self.records[i];
        GlossyLobe { bsdf: &self.bsdfs[r.bsdf as usize], wo: Vec3::from(r.wo), frame: Frame::from_normal(Vec3::from(r.ns)) }
    }

    /// Sample `i` ready to evaluate (the BSDF's per-`wo` work done: build it once per sample, not
    /// per evaluation).
    #[inline]
    pub fn sample(&self, i: usize) -> GlossySample {
        let r = &self.records[i];
        GlossySample { bsdf: self.bsdfs[r.bsdf as usize].at(Vec3::from(r.wo)), frame: Frame::from_normal(Vec3::from(r.ns)) }
    }

    pub fn bytes(&self) -> u64 {
        (self.records.len() * std::mem::size_of::<GlossyRecord>() + self.bsdfs.len() * std::mem::size_of::<Bsdf>()) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::SurfaceParams;
    use crate::sampling::{hash, Rng};

    /// The compact table gives back every sample as it was pushed, bit for bit (the BSDF with its
    /// per-`wo` context, the frame, and every evaluation), and stores a BSDF once per run of
    /// samples sharing it.
    #[test]
    fn glossy_table_gives_back_the_samples() {
        let mut rng = Rng::new(hash(&[0x47_4c_4f]), 0);
        let mut unit = || {
            let (a, b) = (rng.next_f32(), rng.next_f32());
            let z = 2.0 * a - 1.0;
            let s = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(s * (std::f32::consts::TAU * b).cos(), s * (std::f32::consts::TAU * b).sin(), z)
        };
        let bsdfs = [
            Bsdf::from_preview_surface(&SurfaceParams::coat(Vec3::new(0.5, 0.3, 0.2), Vec3::ONE, false, 0.3)),
            Bsdf::from_preview_surface(&SurfaceParams::coat(Vec3::new(0.1, 0.6, 0.2), Vec3::ONE, false, 0.05)),
            Bsdf::lambert(Vec3::new(0.8, 0.5, 0.2)),
        ];
        // runs of 1 to 5 samples per BSDF
        let mut samples = Vec::new();
        let mut runs = 0;
        for k in 0..60usize {
            runs += 1;
            for _ in 0..1 + k % 5 {
                let n = unit();
                let frame = Frame::from_normal(n);
                let wo = frame.to_local(unit());
                samples.push(GlossySample { bsdf: bsdfs[k % 3].at(wo), frame });
            }
        }
        let table = GlossyTable::from_samples(samples.iter().copied());
        assert_eq!(table.len(), samples.len());
        assert_eq!(table.bsdfs.len(), runs);
        assert!(table.bytes() < (samples.len() * std::mem::size_of::<GlossySample>()) as u64 / 2);
        for (i, g) in samples.iter().enumerate() {
            let (got, lobe) = (table.sample(i), table.lobe(i));
            assert_eq!(got.bsdf.bsdf(), g.bsdf.bsdf());
            assert_eq!(lobe.bsdf, g.bsdf.bsdf());
            assert_eq!((got.bsdf.wo(), lobe.wo), (g.bsdf.wo(), g.bsdf.wo()));
            assert_eq!((got.frame.s, got.frame.t, got.frame.n), (g.frame.s, g.frame.t, g.frame.n));
            assert_eq!((lobe.frame.s, lobe.frame.t, lobe.frame.n), (g.frame.s, g.frame.t, g.frame.n));
            for _ in 0..8 {
                let wi = unit();
                assert_eq!(got.eval(wi).to_array().map(f32::to_bits), g.eval(wi).to_array().map(f32::to_bits), "sample {i}, wi {wi}");
            }
        }
    }
}
