//! Tests of the Embree wrapper against a brute-force Möller–Trumbore reference (in f64).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use glam::{DVec3, Mat4, Quat, Vec3};
use rayon::prelude::*;

use super::*;
use crate::Error;

/// Small deterministic RNG (splitmix64).
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = self.vec(-1.0, 1.0);
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
    fn rotation(&mut self) -> Quat {
        Quat::from_axis_angle(self.dir(), self.range(0.0, std::f32::consts::TAU))
    }
}

/// A random triangle soup: `n` triangles of size ~`size` centred in `[-1, 1]^3`.
fn soup(rng: &mut Rng, n: usize, size: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut pos = Vec::new();
    let mut idx = Vec::new();
    for i in 0..n as u32 {
        let c = rng.vec(-1.0, 1.0);
        for _ in 0..3 {
            pos.push(c + rng.vec(-size, size));
        }
        idx.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    (pos, idx)
}

/// A world-space triangle of the reference: (instance, prim, vertices).
type RefTri = (u32, u32, [Vec3; 3]);

/// The reference world: what the scene builder was given, transformed to world space.
#[derive(Default)]
struct Reference {
    meshes: Vec<(Vec<Vec3>, Vec<[u32; 3]>)>,
    tris: Vec<RefTri>,
}

impl Reference {
    fn add_mesh(&mut self, b: &mut SceneBuilder, pos: Vec<Vec3>, idx: Vec<[u32; 3]>) -> MeshId {
        let id = b.add_mesh(&pos, &idx).unwrap();
        assert_eq!(id.0 as usize, self.meshes.len());
        self.meshes.push((pos, idx));
        id
    }
    fn add_instance(&mut self, b: &mut SceneBuilder, mesh: MeshId, xf: Mat4) -> u32 {
        let inst = b.add_instance(mesh, xf).unwrap();
        let (pos, idx) = &self.meshes[mesh.0 as usize];
        for (prim, t) in idx.iter().enumerate() {
            self.tris.push((
                inst,
                prim as u32,
                t.map(|i| xf.transform_point3(pos[i as usize])),
            ));
        }
        inst
    }
    /// All hits `(t, u, v, tri)` of `ray` within its interval, sorted by t.
    fn hits(&self, ray: &Ray) -> Vec<(f64, f64, f64, &RefTri)> {
        let mut v: Vec<_> = self
            .tris
            .iter()
            .filter_map(|tri| moller_trumbore(ray, &tri.2).map(|(t, u, v)| (t, u, v, tri)))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    }
}

/// Möller–Trumbore in f64: `(t, u, v)` of the hit within `[tnear, tfar]`, both faces.
fn moller_trumbore(ray: &Ray, p: &[Vec3; 3]) -> Option<(f64, f64, f64)> {
    let [p0, p1, p2] = p.map(|p| p.as_dvec3());
    let (o, d) = (ray.org.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-14 {
        return None;
    }
    let tv = o - p0;
    let u = tv.dot(pv) / det;
    let qv = tv.cross(e1);
    let v = d.dot(qv) / det;
    let t = e2.dot(qv) / det;
    let inside = u >= 0.0 && v >= 0.0 && u + v <= 1.0;
    (inside && t >= ray.tnear as f64 && t <= ray.tfar as f64).then_some((t, u, v))
}

/// Smallest barycentric coordinate: how far inside its triangle a hit is.
fn edge_distance(u: f64, v: f64) -> f64 {
    u.min(v).min(1.0 - u - v)
}

fn world_normal(p: &[Vec3; 3]) -> DVec3 {
    let [p0, p1, p2] = p.map(|p| p.as_dvec3());
    (p1 - p0).cross(p2 - p0)
}

/// A random affine transform: rotation, (non-uniform, optionally mirroring) scale, translation.
fn random_transform(rng: &mut Rng, mirror: bool) -> Mat4 {
    let mut s = rng.vec(0.5, 2.0);
    if mirror {
        s.x = -s.x;
    }
    Mat4::from_translation(rng.vec(-3.0, 3.0))
        * Mat4::from_quat(rng.rotation())
        * Mat4::from_scale(s)
}

/// Random rays from a box around the scene towards random points inside it.
fn random_rays(rng: &mut Rng, n: usize, extent: f32) -> Vec<Ray> {
    (0..n)
        .map(|_| {
            let o = rng.vec(-extent * 1.5, extent * 1.5);
            let target = rng.vec(-extent, extent);
            Ray::new(o, (target - o) * rng.range(0.5, 2.0))
        })
        .collect()
}

/// Compare `scene.intersect` with the reference on `rays`; returns the number of hits checked.
/// Disagreements are allowed only where the reference itself is ambiguous: a hit within 1e-4 of
/// a triangle edge, or two triangles at (nearly) the same t.
fn check_against_reference(scene: &Scene, reference: &Reference, rays: &[Ray]) -> usize {
    let mut checked = 0;
    let mut ambiguous = 0;
    for ray in rays {
        let want = reference.hits(ray);
        let got = scene.intersect(ray);
        let Some(&(t, u, v, tri)) = want.first() else {
            if let Some(h) = got {
                // Embree may catch a grazing hit the reference misses only right at an edge.
                assert!(
                    edge_distance(h.u as f64, h.v as f64) < 1e-4,
                    "spurious hit {h:?} for {ray:?}"
                );
                ambiguous += 1;
            }
            continue;
        };
        let tie = want
            .get(1)
            .is_some_and(|w| (w.0 - t).abs() <= 1e-4 * t.abs().max(1e-3));
        let near_edge = edge_distance(u, v) < 1e-4;
        let Some(h) = got else {
            assert!(
                near_edge || tie,
                "missed hit t={t} prim={} inst={} for {ray:?}",
                tri.1,
                tri.0
            );
            ambiguous += 1;
            continue;
        };
        if (h.instance, h.prim) != (tri.0, tri.1) {
            assert!(
                near_edge || tie,
                "hit {h:?}, expected inst {} prim {} t {t} for {ray:?}",
                tri.0,
                tri.1
            );
            ambiguous += 1;
            continue;
        }
        checked += 1;
        assert!(
            (h.t as f64 - t).abs() <= 1e-4 * t.abs().max(1e-3),
            "t {} vs {t} for {ray:?}",
            h.t
        );
        assert!(
            (h.u as f64 - u).abs() < 1e-3 && (h.v as f64 - v).abs() < 1e-3,
            "uv ({}, {}) vs ({u}, {v})",
            h.u,
            h.v
        );
        let n = world_normal(&tri.2).normalize();
        let cos = h.ng.as_dvec3().normalize().dot(n);
        assert!(
            cos > 0.9999,
            "ng {:?} vs {n:?} (cos {cos}) inst {}",
            h.ng,
            h.instance
        );
    }
    assert!(
        ambiguous * 100 <= rays.len(),
        "{ambiguous} ambiguous of {} rays",
        rays.len()
    );
    checked
}

fn device() -> Device {
    Device::new(2).expect("embree device")
}

#[test]
fn flattened_meshes_match_brute_force() {
    let mut rng = Rng(1);
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let mut r = Reference::default();
    for k in 0..3 {
        let (p, i) = soup(&mut rng, 150, 0.4);
        let m = r.add_mesh(&mut b, p, i);
        // One placement each (the last one mirrored) → all flattened.
        let xf = if k == 0 {
            Mat4::IDENTITY
        } else {
            random_transform(&mut rng, k == 2)
        };
        assert_eq!(r.add_instance(&mut b, m, xf), k);
    }
    let scene = b.commit().unwrap();
    let rays = random_rays(&mut rng, 6000, 3.0);
    let checked = check_against_reference(&scene, &r, &rays);
    assert!(checked > 1500, "only {checked} hits checked");
}

#[test]
fn multi_instanced_meshes_match_brute_force() {
    let mut rng = Rng(2);
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let mut r = Reference::default();
    let mut next = 0;
    for k in 0..3 {
        let (p, i) = soup(&mut rng, 60, 0.5);
        let m = r.add_mesh(&mut b, p, i);
        // Meshes 0 and 1 are instanced 4 times (some mirrored); mesh 2 is placed once (flattened).
        let copies = if k == 2 { 1 } else { 4 };
        for c in 0..copies {
            let inst = r.add_instance(&mut b, m, random_transform(&mut rng, c % 2 == 1));
            assert_eq!(inst, next);
            next += 1;
        }
    }
    let scene = b.commit().unwrap();
    let rays = random_rays(&mut rng, 5000, 4.0);
    let checked = check_against_reference(&scene, &r, &rays);
    assert!(checked > 1500, "only {checked} hits checked");
    // Every instance is actually hit somewhere.
    let mut seen = [false; 9];
    for ray in &rays {
        if let Some(h) = scene.intersect(ray) {
            seen[h.instance as usize] = true;
        }
    }
    assert!(seen.iter().all(|&s| s), "instances hit: {seen:?}");
}

#[test]
fn occluded_respects_segments() {
    let mut rng = Rng(3);
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let mut r = Reference::default();
    let (p, i) = soup(&mut rng, 100, 0.4);
    let m = r.add_mesh(&mut b, p, i);
    r.add_instance(&mut b, m, Mat4::IDENTITY);
    let (p, i) = soup(&mut rng, 50, 0.4);
    let m = r.add_mesh(&mut b, p, i);
    r.add_instance(&mut b, m, random_transform(&mut rng, false));
    r.add_instance(&mut b, m, random_transform(&mut rng, true));
    let scene = b.commit().unwrap();
    let (mut tested, mut blocked, mut mismatches) = (0, 0, 0);
    for ray in random_rays(&mut rng, 4000, 3.0) {
        let (a, c) = (rng.range(0.0, 1.5), rng.range(0.0, 1.5));
        let seg = Ray::segment(ray.org, ray.dir, a.min(c), a.max(c));
        let ts: Vec<f64> = r
            .hits(&Ray::new(seg.org, seg.dir))
            .iter()
            .map(|h| h.0)
            .collect();
        let (lo, hi) = (seg.tnear as f64, seg.tfar as f64);
        if ts
            .iter()
            .any(|&t| (t - lo).abs() < 1e-4 || (t - hi).abs() < 1e-4)
        {
            continue; // a hit at the segment's end: either answer is right
        }
        let want = ts.iter().any(|&t| t >= lo && t <= hi);
        let got = scene.occluded(&seg);
        // Grazing edge hits may differ (see `check_against_reference`).
        mismatches += (got != want) as usize;
        tested += 1;
        blocked += want as usize;
        // The segment [tnear, tfar] also bounds intersect.
        if let Some(h) = scene.intersect(&seg) {
            assert!(h.t >= seg.tnear && h.t <= seg.tfar, "{h:?} outside {seg:?}");
        }
    }
    assert!(
        tested > 3000 && blocked > 300 && blocked + 300 < tested,
        "tested {tested}, blocked {blocked}"
    );
    assert!(
        mismatches * 200 <= tested,
        "{mismatches} of {tested} segments disagree with the reference"
    );
}

#[test]
fn tnear_and_tfar_are_respected() {
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    // Two parallel squares at z = 1 and z = 2 (4 triangles).
    let mut pos = Vec::new();
    let mut idx = Vec::new();
    for (k, z) in [1.0f32, 2.0].into_iter().enumerate() {
        let base = pos.len() as u32;
        pos.extend([
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ]);
        idx.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        assert_eq!(idx.len(), 2 * k + 2);
    }
    let m = b.add_mesh(&pos, &idx).unwrap();
    b.add_instance(m, Mat4::IDENTITY).unwrap();
    let scene = b.commit().unwrap();
    let (o, d) = (Vec3::new(0.3, -0.2, 0.0), Vec3::Z);
    let h = scene.intersect(&Ray::new(o, d)).unwrap();
    assert!((h.t - 1.0).abs() < 1e-6 && h.prim < 2, "{h:?}");
    assert!(
        h.ng.z > 0.0,
        "counter-clockwise seen from +z: ng {:?}",
        h.ng
    );
    let h = scene
        .intersect(&Ray::segment(o, d, 1.5, f32::INFINITY))
        .unwrap();
    assert!((h.t - 2.0).abs() < 1e-6 && h.prim >= 2, "{h:?}");
    assert!(scene.intersect(&Ray::segment(o, d, 0.0, 0.9)).is_none());
    assert!(scene.intersect(&Ray::segment(o, d, 2.1, 10.0)).is_none());
    assert!(scene.intersect(&Ray::new(o, -d)).is_none());
    assert!(scene.occluded(&Ray::segment(o, d, 0.0, 1.1)));
    assert!(!scene.occluded(&Ray::segment(o, d, 0.0, 0.9)));
    assert!(!scene.occluded(&Ray::segment(o, d, 1.1, 1.9)));
    assert!(scene.occluded(&Ray::segment(o, d, 1.1, 2.1)));
    // t is in units of dir.
    let h = scene.intersect(&Ray::new(o, d * 4.0)).unwrap();
    assert!((h.t - 0.25).abs() < 1e-6, "{h:?}");
    // Barycentrics: p = (1-u-v) p0 + u p1 + v p2.
    let tri = idx[h.prim as usize].map(|i| pos[i as usize]);
    let p = tri[0] * (1.0 - h.u - h.v) + tri[1] * h.u + tri[2] * h.v;
    assert!((p - (o + d)).length() < 1e-5, "{p} vs {}", o + d);
}

#[test]
fn batch_equals_single() {
    let mut rng = Rng(4);
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let (p, i) = soup(&mut rng, 200, 0.4);
    let m = b.add_mesh(&p, &i).unwrap();
    b.add_instance(m, Mat4::IDENTITY).unwrap();
    let (p, i) = soup(&mut rng, 80, 0.4);
    let m = b.add_mesh(&p, &i).unwrap();
    for _ in 0..3 {
        b.add_instance(m, random_transform(&mut rng, false))
            .unwrap();
    }
    let scene = b.commit().unwrap();
    // Incoherent random rays and coherent "camera" rays; 1000 is not a multiple of the batch size.
    let random = random_rays(&mut rng, 1000, 3.0);
    let eye = Vec3::new(0.0, 0.0, -6.0);
    let camera: Vec<Ray> = (0..1000)
        .map(|k| {
            Ray::new(
                eye,
                Vec3::new(
                    (k % 40) as f32 / 20.0 - 1.0,
                    (k / 40) as f32 / 12.5 - 1.0,
                    3.0,
                ),
            )
        })
        .collect();
    for (rays, coherent) in [
        (&random, false),
        (&random, true),
        (&camera, true),
        (&camera, false),
    ] {
        let mut hits = vec![None; rays.len()];
        scene.intersect_batch(rays, &mut hits, coherent);
        let mut occ = vec![false; rays.len()];
        scene.occluded_batch(rays, &mut occ, coherent);
        let mut n_hits = 0;
        for (k, ray) in rays.iter().enumerate() {
            let single = scene.intersect(ray);
            match (hits[k], single) {
                (Some(a), Some(s)) => {
                    assert_eq!((a.instance, a.prim), (s.instance, s.prim), "ray {k}");
                    assert!((a.t - s.t).abs() <= 1e-5 * s.t, "ray {k}: {a:?} vs {s:?}");
                    assert!((a.ng.normalize() - s.ng.normalize()).length() < 1e-4);
                    n_hits += 1;
                }
                (None, None) => {}
                (a, s) => panic!("ray {k} coherent={coherent}: batch {a:?}, single {s:?}"),
            }
            assert_eq!(occ[k], scene.occluded(ray), "ray {k} coherent={coherent}");
            assert_eq!(occ[k], hits[k].is_some(), "ray {k}: occluded vs hit");
        }
        assert!(n_hits > 100 && n_hits < rays.len(), "{n_hits} hits");
    }
    // Empty batches are fine.
    scene.intersect_batch(&[], &mut [], true);
    scene.occluded_batch(&[], &mut [], false);
}

#[test]
#[should_panic(expected = "differ in length")]
fn batch_length_mismatch_panics() {
    let scene = SceneBuilder::new(&device()).unwrap().commit().unwrap();
    scene.intersect_batch(&[Ray::new(Vec3::ZERO, Vec3::X)], &mut [], false);
}

#[test]
fn scene_is_send_sync_and_parallel_queries_agree() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Scene>();
    assert_send_sync::<Device>();
    assert_send_sync::<SceneBuilder>();
    assert_send_sync::<Ray>();
    assert_send_sync::<Hit>();

    let mut rng = Rng(5);
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let (p, i) = soup(&mut rng, 300, 0.3);
    let m = b.add_mesh(&p, &i).unwrap();
    b.add_instance(m, Mat4::IDENTITY).unwrap();
    b.add_instance(m, random_transform(&mut rng, false))
        .unwrap();
    let scene = b.commit().unwrap();
    let rays = random_rays(&mut rng, 20_000, 3.0);
    let sequential: Vec<Option<Hit>> = rays.iter().map(|r| scene.intersect(r)).collect();
    let parallel: Vec<Option<Hit>> = rays
        .par_chunks(256)
        .flat_map_iter(|chunk| {
            set_flush_denormals();
            let mut hits = vec![None; chunk.len()];
            scene.intersect_batch(chunk, &mut hits, false);
            hits
        })
        .collect();
    assert_eq!(sequential, parallel);
    let n_occluded = rays.par_iter().filter(|r| scene.occluded(r)).count();
    assert_eq!(
        n_occluded,
        sequential.iter().filter(|h| h.is_some()).count()
    );
    // The scene can also be moved to another thread and dropped there.
    let h = std::thread::spawn(move || scene.intersect(&rays[0]))
        .join()
        .unwrap();
    assert_eq!(h, sequential[0]);
}

/// A stack of unit-ish triangles at z = 0, 1, ..., n-1 (prim k at z = k), all facing +z.
fn stack(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut pos = Vec::new();
    for k in 0..n {
        let z = k as f32;
        pos.extend([
            Vec3::new(-2.0, -2.0, z),
            Vec3::new(3.0, -2.0, z),
            Vec3::new(-2.0, 3.0, z),
        ]);
    }
    (pos, (0..n).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect())
}

#[test]
fn filter_rejects_hits_flattened_and_instanced() {
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let (p, i) = stack(6);
    let flat = b.add_mesh(&p, &i).unwrap();
    let inst = b.add_mesh(&p, &i).unwrap();
    let calls = Arc::new(AtomicUsize::new(0));
    let c = calls.clone();
    // Flattened mesh: reject even prims.
    let even: FilterFn = Arc::new(move |_inst, prim, _u, _v| {
        c.fetch_add(1, Ordering::Relaxed);
        prim % 2 == 1
    });
    b.set_filter(flat, even.clone());
    // Instanced mesh: instance 1 is fully transparent, instance 2 rejects prims < 3.
    b.set_filter(
        inst,
        Arc::new(|inst, prim, u, v| {
            assert!((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v) && u + v <= 1.0 + 1e-6);
            inst == 2 && prim >= 3
        }),
    );
    assert_eq!(b.add_instance(flat, Mat4::IDENTITY).unwrap(), 0);
    let shift = Mat4::from_translation(Vec3::new(100.0, 0.0, 0.0));
    assert_eq!(b.add_instance(inst, shift).unwrap(), 1);
    assert_eq!(
        b.add_instance(inst, Mat4::from_translation(Vec3::new(200.0, 0.0, 0.0)))
            .unwrap(),
        2
    );
    let scene = b.commit().unwrap();
    assert_eq!(
        Arc::strong_count(&even),
        2,
        "the scene keeps the filter alive"
    );

    let up = |x: f32| Ray::new(Vec3::new(x, 0.0, -1.0), Vec3::Z);
    let h = scene.intersect(&up(0.0)).unwrap();
    assert_eq!((h.instance, h.prim), (0, 1));
    assert!((h.t - 2.0).abs() < 1e-5, "{h:?}");
    assert!(
        calls.load(Ordering::Relaxed) >= 2,
        "filter called for prims 0 and 1"
    );
    // From above, going down: prim 5 (odd) is the first hit.
    let h = scene
        .intersect(&Ray::new(Vec3::new(0.0, 0.0, 10.0), -Vec3::Z))
        .unwrap();
    assert_eq!((h.instance, h.prim), (0, 5));
    // Segments covering only rejected prims are not occluded.
    assert!(!scene.occluded(&Ray::segment(Vec3::new(0.0, 0.0, -1.0), Vec3::Z, 0.0, 1.5)));
    assert!(scene.occluded(&Ray::segment(Vec3::new(0.0, 0.0, -1.0), Vec3::Z, 0.0, 2.5)));
    // Instance 1 is invisible; instance 2 is hit at its prim 3.
    assert!(scene.intersect(&up(100.0)).is_none());
    assert!(!scene.occluded(&up(100.0)));
    let h = scene.intersect(&up(200.0)).unwrap();
    assert_eq!((h.instance, h.prim), (2, 3));
    assert!((h.t - 4.0).abs() < 1e-5);

    // Batched and coherent paths (Embree may call the filter with packets) agree with single rays.
    let rays: Vec<Ray> = (0..300)
        .map(|k| up([0.0, 100.0, 200.0][k % 3] + (k / 3) as f32 * 0.01))
        .collect();
    for coherent in [false, true] {
        let mut hits = vec![None; rays.len()];
        scene.intersect_batch(&rays, &mut hits, coherent);
        let mut occ = vec![false; rays.len()];
        scene.occluded_batch(&rays, &mut occ, coherent);
        for (k, r) in rays.iter().enumerate() {
            let want = [Some((0, 1)), None, Some((2, 3))][k % 3];
            assert_eq!(
                hits[k].map(|h| (h.instance, h.prim)),
                want,
                "ray {k} coherent={coherent}"
            );
            assert_eq!(occ[k], want.is_some());
            assert_eq!(scene.intersect(r).map(|h| (h.instance, h.prim)), want);
        }
    }
    drop(scene);
    assert_eq!(
        Arc::strong_count(&even),
        1,
        "dropping the scene releases the filter"
    );
}

#[test]
fn panicking_filter_keeps_the_hit() {
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let (p, i) = stack(2);
    let m = b.add_mesh(&p, &i).unwrap();
    b.set_filter(
        m,
        Arc::new(|_, _, _, _| panic!("filter panic (expected by the test)")),
    );
    b.add_instance(m, Mat4::IDENTITY).unwrap();
    let scene = b.commit().unwrap();
    let h = scene
        .intersect(&Ray::new(Vec3::new(0.0, 0.0, -1.0), Vec3::Z))
        .unwrap();
    assert_eq!(h.prim, 0);
}

#[test]
fn empty_scenes_miss() {
    let dev = device();
    let scene = SceneBuilder::new(&dev).unwrap().commit().unwrap();
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(scene.intersect(&ray).is_none());
    assert!(!scene.occluded(&ray));
    assert_eq!(scene.bounds(), (Vec3::ZERO, Vec3::ZERO));
    let mut hits = vec![
        Some(Hit {
            t: 1.0,
            u: 0.0,
            v: 0.0,
            instance: 7,
            prim: 7,
            ng: Vec3::X
        });
        3
    ];
    scene.intersect_batch(&[ray; 3], &mut hits, true);
    assert_eq!(hits, vec![None; 3]);

    // Meshes without instances, and instances of a mesh without triangles, are empty too.
    let mut b = SceneBuilder::new(&dev).unwrap();
    let (p, i) = stack(3);
    b.add_mesh(&p, &i).unwrap();
    let empty = b.add_mesh(&[], &[]).unwrap();
    assert_eq!(b.add_instance(empty, Mat4::IDENTITY).unwrap(), 0);
    assert_eq!(b.add_instance(empty, Mat4::IDENTITY).unwrap(), 1);
    let scene = b.commit().unwrap();
    assert!(scene
        .intersect(&Ray::new(Vec3::new(0.0, 0.0, -1.0), Vec3::Z))
        .is_none());
    assert_eq!(scene.bounds(), (Vec3::ZERO, Vec3::ZERO));
}

#[test]
fn degenerate_triangles_do_not_crash() {
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let pos = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(2.0, 0.0, 1.0), // collinear with the first two
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::new(f32::NAN, 0.0, 1.0),
        Vec3::new(f32::INFINITY, 5.0, 1.0),
    ];
    // collinear, repeated vertex, NaN vertex, infinite vertex, then a good triangle (prim 4).
    let idx = [[0, 1, 2], [0, 0, 3], [4, 1, 3], [5, 1, 3], [0, 1, 3]];
    let m = b.add_mesh(&pos, &idx).unwrap();
    b.add_instance(m, Mat4::IDENTITY).unwrap();
    b.add_instance(m, Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0)))
        .unwrap();
    let scene = b.commit().unwrap();
    for x in [0.0, 10.0] {
        let h = scene
            .intersect(&Ray::new(Vec3::new(x + 0.2, 0.2, 0.0), Vec3::Z))
            .unwrap();
        assert_eq!(h.prim, 4);
        assert!((h.t - 1.0).abs() < 1e-6);
        // Along the degenerate edge: no hit on a degenerate triangle is ever reported.
        if let Some(h) = scene.intersect(&Ray::new(Vec3::new(x + 1.5, 0.0, 0.0), Vec3::Z)) {
            assert_eq!(h.prim, 4, "{h:?}");
        }
    }
    // Bounds ignore the triangles with non-finite vertices.
    assert_eq!(
        scene.bounds(),
        (Vec3::new(0.0, 0.0, 1.0), Vec3::new(12.0, 1.0, 1.0))
    );
}

#[test]
fn bounds_are_correct() {
    let mut rng = Rng(6);
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let mut r = Reference::default();
    let (p, i) = soup(&mut rng, 50, 0.3);
    let flat = r.add_mesh(&mut b, p, i);
    let xf = random_transform(&mut rng, false);
    r.add_instance(&mut b, flat, xf);
    let scene = b.commit().unwrap();
    // Flattened: exactly the box of the world-space vertices.
    let pts = || r.tris.iter().flat_map(|t| t.2);
    let (lo, hi) = (
        pts().fold(Vec3::INFINITY, Vec3::min),
        pts().fold(Vec3::NEG_INFINITY, Vec3::max),
    );
    assert_eq!(scene.bounds(), (lo, hi));

    // Instanced: contains every world vertex, and is the box of the transformed object-space box.
    let mut b = SceneBuilder::new(&dev).unwrap();
    let mut r = Reference::default();
    let (p, i) = soup(&mut rng, 50, 0.3);
    let (olo, ohi) = (
        p.iter().copied().fold(Vec3::INFINITY, Vec3::min),
        p.iter().copied().fold(Vec3::NEG_INFINITY, Vec3::max),
    );
    let m = r.add_mesh(&mut b, p, i);
    let xfs = [
        random_transform(&mut rng, false),
        random_transform(&mut rng, true),
    ];
    for xf in xfs {
        r.add_instance(&mut b, m, xf);
    }
    let scene = b.commit().unwrap();
    let (lo, hi) = scene.bounds();
    for p in r.tris.iter().flat_map(|t| t.2) {
        assert!(
            p.cmpge(lo - 1e-5).all() && p.cmple(hi + 1e-5).all(),
            "{p} outside {lo}..{hi}"
        );
    }
    let mut want = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for xf in xfs {
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 != 0 { ohi.x } else { olo.x },
                if k & 2 != 0 { ohi.y } else { olo.y },
                if k & 4 != 0 { ohi.z } else { olo.z },
            );
            let w = xf.transform_point3(c);
            want = (want.0.min(w), want.1.max(w));
        }
    }
    assert!((lo - want.0).abs().max_element() < 1e-5 && (hi - want.1).abs().max_element() < 1e-5);
}

#[test]
fn invalid_input_is_an_error() {
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let pos = [Vec3::ZERO, Vec3::X, Vec3::Y];
    assert!(matches!(
        b.add_mesh(&pos, &[[0, 1, 3]]),
        Err(Error::Param { .. })
    ));
    let m = b.add_mesh(&pos, &[[0, 1, 2]]).unwrap();
    assert!(matches!(
        b.add_instance(MeshId(5), Mat4::IDENTITY),
        Err(Error::Param { .. })
    ));
    let mut projective = Mat4::IDENTITY;
    projective.x_axis.w = 0.5;
    assert!(matches!(
        b.add_instance(m, projective),
        Err(Error::Param { .. })
    ));
    assert!(matches!(
        b.add_instance(m, Mat4::from_scale(Vec3::splat(f32::NAN))),
        Err(Error::Param { .. })
    ));
    assert_eq!(
        b.add_instance(m, Mat4::IDENTITY).unwrap(),
        0,
        "failed calls do not consume indices"
    );
    assert!(Device::new(0).is_ok());
}

#[test]
fn scene_outlives_device_handle_and_builder() {
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let (p, i) = stack(1);
    let m = b.add_mesh(&p, &i).unwrap();
    b.add_instance(m, Mat4::IDENTITY).unwrap();
    b.add_instance(m, Mat4::from_translation(Vec3::X * 10.0))
        .unwrap();
    drop(dev);
    let scene = b.commit().unwrap();
    let h = scene
        .intersect(&Ray::new(Vec3::new(10.0, 0.0, -1.0), Vec3::Z))
        .unwrap();
    assert_eq!(h.instance, 1);
    assert!(h.ng.z > 0.0);
}

#[test]
fn flush_denormals_sets_ftz_daz() {
    set_flush_denormals();
    set_flush_denormals();
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: reading MXCSR has no side effects.
        #[allow(deprecated)]
        let csr = unsafe { std::arch::x86_64::_mm_getcsr() };
        assert_eq!(csr & 0x8040, 0x8040);
        let tiny = std::hint::black_box(f32::MIN_POSITIVE);
        assert_eq!(
            std::hint::black_box(tiny * 0.5),
            0.0,
            "denormal results flush to zero"
        );
    }
}

/// `timing` counts cycles only while on, for all four kinds of query, and the results of the
/// queries do not change.
#[cfg(feature = "embree-timing")]
#[test]
fn timing_counts_only_when_on() {
    let mut rng = Rng(9);
    let dev = device();
    let mut b = SceneBuilder::new(&dev).unwrap();
    let mut r = Reference::default();
    let (p, i) = soup(&mut rng, 200, 0.4);
    let m = r.add_mesh(&mut b, p, i);
    r.add_instance(&mut b, m, Mat4::IDENTITY);
    let scene = b.commit().unwrap();
    let rays = random_rays(&mut rng, 512, 3.0);
    let run = || {
        let single: Vec<(Option<Hit>, bool)> = rays.iter().map(|ray| (scene.intersect(ray), scene.occluded(ray))).collect();
        let mut hits = vec![None; rays.len()];
        let mut occ = vec![false; rays.len()];
        scene.intersect_batch(&rays, &mut hits, false);
        scene.occluded_batch(&rays, &mut occ, false);
        (single, hits, occ)
    };
    super::timing::set_counting(false);
    let off = run();
    assert_eq!(super::timing::counted_cycles(), 0);
    super::timing::set_counting(true);
    let on = run();
    let counted = super::timing::counted_cycles();
    super::timing::set_counting(false);
    assert!(on == off, "timing changed a query's result");
    if super::timing::cycles_now() > 0 {
        assert!(counted > 0, "nothing counted");
    }
}

#[test]
fn device_reports_the_embree_it_was_built_with() {
    let version = device().version();
    let major = if cfg!(feature = "embree4") { "4." } else { "3." };
    assert!(version.starts_with(major), "Embree {version} in a build for {major}x");
}
