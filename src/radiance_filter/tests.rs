use super::*;
use crate::sampling::Rng;

const W: u32 = 40;
const H: u32 = 30;

/// Left half: a wall at depth 2 facing +z; right half: a wall at depth 5 (a depth jump at x = 20);
/// the bottom rows of the left half bend to a floor (normal +y, a crease at y = 24).
fn scene() -> (Vec<f32>, Vec<Vec3>) {
    let mut depth = vec![0.0; (W * H) as usize];
    let mut normal = vec![Vec3::ZERO; (W * H) as usize];
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            depth[i] = if x < 20 { 2.0 + 0.001 * y as f32 } else { 5.0 };
            normal[i] = if x < 20 && y >= 24 { Vec3::Y } else { Vec3::Z };
        }
    }
    depth[0] = 0.0; // background pixel
    (depth, normal)
}

#[test]
fn segmentation_splits_at_depth_jumps_and_creases_only() {
    let (depth, normal) = scene();
    let p = FilterParams::with_radius(4);
    let (label, n) = segment(W, H, &depth, &normal, &p);
    assert_eq!(n, 3);
    assert_eq!(label[0], u32::MAX);
    let at = |x: u32, y: u32| label[(y * W + x) as usize];
    assert_eq!(at(1, 0), at(19, 23));
    assert_ne!(at(19, 23), at(20, 23));
    assert_ne!(at(5, 23), at(5, 24));
    assert_eq!(at(20, 0), at(39, 29));
}

#[test]
fn filter_keeps_constants_reduces_noise_and_never_crosses_discontinuities() {
    let (depth, normal) = scene();
    let p = FilterParams::with_radius(3);
    let (label, n) = segment(W, H, &depth, &normal, &p);
    let mut rng = Rng::new(7, 0);
    // segment values 1, 1000, 5 (+ noise on the first)
    let truth = |i: usize| if (i as u32 % W) >= 20 { 1000.0 } else if i as u32 / W >= 24 { 5.0 } else { 1.0 };
    let mut data: Vec<Vec3> = (0..(W * H) as usize).map(|i| Vec3::splat(truth(i) * if truth(i) == 1.0 { 0.5 + rng.next_f32() } else { 1.0 })).collect();
    let before = data.clone();
    let weight = vec![1.0f32; (W * H) as usize];
    let (r, _) = filter_records(W, H, &label, n, &weight, &|i| Some(i), 1, &mut data, &p);
    // target 9 mean weights with uniform weights: radius 1 in the interior
    assert!((1.0..1.6).contains(&r), "mean radius {r}");
    let var = |d: &[Vec3]| {
        let v: Vec<f32> = (0..d.len()).filter(|&i| truth(i) == 1.0 && label[i] != u32::MAX).map(|i| d[i].x).collect();
        let m = v.iter().sum::<f32>() / v.len() as f32;
        (m, v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / v.len() as f32)
    };
    let ((m0, v0), (m1, v1)) = (var(&before), var(&data));
    assert!(v1 < 0.3 * v0, "variance {v0} -> {v1}");
    assert!((m1 - m0).abs() < 0.05, "mean {m0} -> {m1}");
    for i in 0..data.len() {
        match truth(i) {
            _ if label[i] == u32::MAX => assert_eq!(data[i], before[i]),
            1.0 => assert!(data[i].x >= 0.5 && data[i].x <= 1.5, "pixel {i}: {}", data[i]),
            t => assert_eq!(data[i].x, t, "pixel {i}"),
        }
    }
}

#[test]
fn low_kernel_weight_widens_the_filter() {
    let (depth, normal) = scene();
    let p = FilterParams::with_radius(6);
    let (label, n) = segment(W, H, &depth, &normal, &p);
    // the top rows of the left wall received 16× less kernel weight than the rest of it
    let weight: Vec<f32> = (0..(W * H) as usize).map(|i| if i as u32 / W < 10 { 0.0625 } else { 1.0 }).collect();
    let mut d = vec![Vec3::ONE; (W * H) as usize];
    let (_, radii) = filter_records(W, H, &label, n, &weight, &|i| Some(i), 1, &mut d, &p);
    let at = |x: u32, y: u32| radii[(y * W + x) as usize];
    assert!(at(10, 3) >= 3 && at(10, 3) > 2 * at(10, 18), "low weight {}, high {}", at(10, 3), at(10, 18));
    assert!(d.iter().all(|v| (*v - Vec3::ONE).abs().max_element() < 1e-6));
}
