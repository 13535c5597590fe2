//! Record radii limited where neighbouring records disagree beyond their noise.
//!
//! A record's radius comes from the harmonic mean distance of the photon rays that reached it (the
//! split-sphere model of [WRC88]), which sees how far the light's sources are, not what occludes
//! them: on a drape half in a column's shadow, lit by photons from across a courtyard, the records
//! of the lit half reach far into the shadowed half. Two records of one segment whose irradiance
//! differs by more than their photon noise explains ([`DISAGREE_SIGMAS`] standard deviations, and
//! at least [`DISAGREE_RELATIVE`] of the larger) see different light; a record then reaches no
//! farther than the nearest record it disagrees with, so the pixels between them are left to
//! the later passes' finer records (the multi-pass cache places records where fewer than
//! `min_records` cover a pixel). Where records agree within their noise, their radii stay, and
//! the cache keeps filtering that noise.

use rayon::prelude::*;

/// Two records disagree when their irradiances differ by more than this many standard deviations
/// of the difference (photon noise, from each record's second moment).
pub const DISAGREE_SIGMAS: f32 = 4.0;
/// ... and by more than this share of the larger irradiance.
pub const DISAGREE_RELATIVE: f32 = 0.25;

/// What the radius limit reads of a record.
#[derive(Clone, Copy, Debug)]
pub struct RecordLight {
    /// Image position (pixel column and row).
    pub x: f32,
    pub y: f32,
    /// Segment of the record's pixel (extrapolation stays within it).
    pub label: u32,
    /// Irradiance summed over the channels (any common scale).
    pub value: f32,
    /// Variance estimate of `value` (the same scale squared).
    pub variance: f32,
}

impl RecordLight {
    /// Whether `self` and `o` see different light.
    #[inline]
    pub fn disagrees(&self, o: &RecordLight) -> bool {
        let d = (self.value - o.value).abs();
        d > DISAGREE_SIGMAS * (self.variance + o.variance).sqrt() && d > DISAGREE_RELATIVE * self.value.max(o.value)
    }
}

/// Limit the radii of the records `records[first..]` (`radius[k]` belongs to `records[first + k]`):
/// each reaches no farther than the nearest record of its segment, among all of `records`, that it
/// reaches and disagrees with (at least 1 pixel). `cell` is the bucket size in pixels, at least the
/// largest radius.
pub fn limit_radii(records: &[RecordLight], first: usize, radius: &mut [f32], width: usize, height: usize, cell: f32) {
    let cell = cell.max(1.0);
    let (cw, ch) = ((width as f32 / cell).ceil().max(1.0) as usize, (height as f32 / cell).ceil().max(1.0) as usize);
    let bucket = |x: f32, y: f32| (((x / cell) as usize).min(cw - 1), ((y / cell) as usize).min(ch - 1));
    // records by bucket, in record order (counting sort)
    let mut start = vec![0u32; cw * ch + 1];
    for r in records {
        let (bx, by) = bucket(r.x, r.y);
        start[by * cw + bx + 1] += 1;
    }
    for i in 0..cw * ch {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut order = vec![0u32; records.len()];
    for (i, r) in records.iter().enumerate() {
        let (bx, by) = bucket(r.x, r.y);
        let k = &mut fill[by * cw + bx];
        order[*k as usize] = i as u32;
        *k += 1;
    }
    radius.par_iter_mut().enumerate().for_each(|(k, rad)| {
        let i = first + k;
        let a = &records[i];
        let (bx, by) = bucket(a.x, a.y);
        let mut limit = *rad;
        for yy in by.saturating_sub(1)..(by + 2).min(ch) {
            for xx in bx.saturating_sub(1)..(bx + 2).min(cw) {
                let b = yy * cw + xx;
                for &j in &order[start[b] as usize..start[b + 1] as usize] {
                    let o = &records[j as usize];
                    if j as usize == i || o.label != a.label {
                        continue;
                    }
                    let d = ((o.x - a.x).powi(2) + (o.y - a.y).powi(2)).sqrt();
                    if d < limit && a.disagrees(o) {
                        limit = d.max(1.0);
                    }
                }
            }
        }
        *rad = limit;
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(x: f32, y: f32, value: f32) -> RecordLight {
        RecordLight { x, y, label: 0, value, variance: 0.001 * value * value }
    }

    #[test]
    fn a_record_stops_at_the_nearest_record_it_disagrees_with() {
        // a lit record at x = 0; at 8 px a record like it, at 12 px a dark one, at 16 px another
        // dark one; then the same dark record on another segment at 5 px
        let mut recs = vec![rec(0.5, 0.5, 1.0), rec(8.5, 0.5, 1.05), rec(12.5, 0.5, 0.2), rec(16.5, 0.5, 0.2)];
        recs.push(RecordLight { label: 1, ..rec(5.5, 0.5, 0.2) });
        let mut radius = vec![24.0; recs.len()];
        limit_radii(&recs, 0, &mut radius, 64, 8, 24.0);
        assert_eq!(radius[0], 12.0); // not 8 (agrees), not 5 (another segment)
        assert_eq!(radius[1], 4.0);
        assert_eq!(radius[2], 4.0);
        assert_eq!(radius[3], 8.0);
        assert_eq!(radius[4], 24.0); // alone on its segment
        // only the records from `first` on are limited
        let mut tail = vec![24.0; 2];
        limit_radii(&recs, 2, &mut tail[..1], 64, 8, 24.0);
        assert_eq!(tail, [4.0, 24.0]);
    }

    #[test]
    fn noise_explains_a_difference() {
        // the same two values with a large variance agree; with a small one they do not
        let (a, b) = (rec(0.5, 0.5, 1.0), rec(8.5, 0.5, 0.6));
        assert!(a.disagrees(&b));
        let noisy = |r: RecordLight| RecordLight { variance: 0.1, ..r };
        assert!(!noisy(a).disagrees(&noisy(b)));
        // and a difference below DISAGREE_RELATIVE never disagrees, however precise
        let exact = |r: RecordLight| RecordLight { variance: 0.0, ..r };
        assert!(!exact(a).disagrees(&exact(rec(8.5, 0.5, 0.8))));
    }
}
