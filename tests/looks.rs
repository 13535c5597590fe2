//! Production looks end to end (USD stage → converter → render): normal maps (UsdPreviewSurface
//! and MaterialX `normalmap`) against the analytic answer and against tilted geometry, the
//! bend that keeps normal-mapped surfaces seen at grazing angles from turning black, the
//! camera's exposure, and texture filtering over ray cones (close-ups as sharp as bilinear
//! lookups, distant checkerboards closer to the converged image at one sample per pixel).

mod common;

use common::{camera_looking, floor, place};
use glam::Vec3;
use raysplat::image::Film;
use raysplat::integrators::{render, MethodSettings, RenderSettings, SilentProgress};
use raysplat::prepare::TextureFilter;
use raysplat::scene::{Light, Material, SceneDesc, TextureDesc, TexturedColor};
use std::path::Path;

/// The angle the normal map tilts the normal by, toward +X (the light's side).
const TILT_DEG: f32 = 30.0;
/// The distant light's angle from the plane's normal.
const LIGHT_DEG: f32 = 80.0;
const ALBEDO: f32 = 0.5;

/// How the test plane is shaded.
#[derive(Clone, Copy, PartialEq)]
enum Look {
    /// MaterialX standard_surface, specular 0 (a Lambertian reflector), its normal from a
    /// `normalmap` node.
    MtlxNormalMap,
    /// MaterialX standard_surface, specular 0, no normal map.
    MtlxPlain,
    /// UsdPreviewSurface with a normal map (UsdUVTexture, scale 2, bias −1).
    PreviewNormalMap,
    /// UsdPreviewSurface without one.
    PreviewPlain,
}

/// A 16-bit PNG of one tangent-space normal `n` (encoded `(n + 1) / 2`).
fn normal_png(path: &Path, n: Vec3) {
    let code = |c: f32| ((c * 0.5 + 0.5) * 65535.0).round() as u16;
    image::ImageBuffer::from_pixel(4, 4, image::Rgb([code(n.x), code(n.y), code(n.z)])).save(path).unwrap();
}

/// A 10 m plane at the origin (normal +Y, `u` along +X, `v` along −Z), turned by `plane_tilt_deg`
/// about Z toward +X, under a distant light of irradiance 1 arriving at `LIGHT_DEG` from +Y on the
/// +X side, seen by a camera at `eye` looking at the origin; `extra_camera` is more USDA for the
/// camera. Written into `dir` with the normal map `normal.png` (tilting by `map_tilt_deg` toward
/// +X in the tangent frame); returns the stage's path.
fn stage(dir: &Path, look: Look, plane_tilt_deg: f32, map_tilt_deg: f32, eye: Vec3, extra_camera: &str) -> std::path::PathBuf {
    let a = map_tilt_deg.to_radians();
    normal_png(&dir.join("normal.png"), Vec3::new(a.sin(), 0.0, a.cos()));
    let material = match look {
        Look::MtlxNormalMap | Look::MtlxPlain => format!(
            r#"def Material "Look"
    {{
        token outputs:mtlx:surface.connect = </Looks/Look/Surface.outputs:out>
        def Shader "Surface"
        {{
            uniform token info:id = "ND_standard_surface_surfaceshader"
            float inputs:base = 1
            color3f inputs:base_color = ({ALBEDO}, {ALBEDO}, {ALBEDO})
            float inputs:specular = 0
            {normal}
            token outputs:out
        }}
        def Shader "NormalMap"
        {{
            uniform token info:id = "ND_normalmap_float"
            vector3f inputs:in.connect = </Looks/Look/Image.outputs:out>
            vector3f outputs:out
        }}
        def Shader "Image"
        {{
            uniform token info:id = "ND_image_vector3"
            asset inputs:file = @./normal.png@
            vector3f outputs:out
        }}
    }}"#,
            normal = if look == Look::MtlxNormalMap { "normal3f inputs:normal.connect = </Looks/Look/NormalMap.outputs:out>" } else { "" }
        ),
        Look::PreviewNormalMap | Look::PreviewPlain => format!(
            r#"def Material "Look"
    {{
        token outputs:surface.connect = </Looks/Look/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = ({ALBEDO}, {ALBEDO}, {ALBEDO})
            float inputs:roughness = 0.6
            {normal}
            token outputs:surface
        }}
        def Shader "Normal"
        {{
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @./normal.png@
            float4 inputs:scale = (2, 2, 2, 1)
            float4 inputs:bias = (-1, -1, -1, 0)
            float2 inputs:st.connect = </Looks/Look/St.outputs:result>
            vector3f outputs:rgb
        }}
        def Shader "St"
        {{
            uniform token info:id = "UsdPrimvarReader_float2"
            string inputs:varname = "st"
            float2 outputs:result
        }}
    }}"#,
            normal = if look == Look::PreviewNormalMap { "normal3f inputs:normal.connect = </Looks/Look/Normal.outputs:rgb>" } else { "" }
        ),
    };
    // the camera looks down its −Z at the origin from `eye`: rotateX by the pitch, then rotateY
    // by the yaw (USD applies rotateXYZ's X first)
    let f = (-eye).normalize();
    let pitch = f.y.asin().to_degrees();
    let yaw = (-f.x).atan2(-f.z).to_degrees();
    let usda = format!(
        r#"#usda 1.0
(
    metersPerUnit = 1
    upAxis = "Y"
)

def Camera "Cam"
{{
    float focalLength = 50
    float horizontalAperture = 4
    float verticalAperture = 4
    float2 clippingRange = (0.01, 1000)
    double3 xformOp:translate = ({ex}, {ey}, {ez})
    float3 xformOp:rotateXYZ = ({pitch}, {yaw}, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    {extra_camera}
}}

def DistantLight "Sun"
{{
    float inputs:intensity = 1
    float inputs:angle = 0
    float3 xformOp:rotateXYZ = (-90, 0, {light})
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}}

def Xform "Tilt"
{{
    float3 xformOp:rotateXYZ = (0, 0, {tilt})
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]

    def Mesh "Plane" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {{
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-5, 0, 5), (5, 0, 5), (5, 0, -5), (-5, 0, -5)]
        normal3f[] normals = [(0, 1, 0), (0, 1, 0), (0, 1, 0), (0, 1, 0)] (
            interpolation = "vertex"
        )
        texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (
            interpolation = "vertex"
        )
        uniform token subdivisionScheme = "none"
        rel material:binding = </Looks/Look>
    }}
}}

def Scope "Looks"
{{
    {material}
}}
"#,
        ex = eye.x,
        ey = eye.y,
        ez = eye.z,
        // the light shines along its −Z: turned down (rotateX −90), then about Z by −LIGHT_DEG to
        // arrive from the +X side
        light = -LIGHT_DEG,
        tilt = -plane_tilt_deg,
    );
    let path = dir.join("stage.usda");
    std::fs::write(&path, usda).unwrap();
    path
}

/// Render `stage` with the path tracer; the film.
fn pt(stage: &Path, spp: u32, size: u32, filter: TextureFilter) -> Film {
    let dir = stage.parent().unwrap();
    let rss = dir.join("stage.rss");
    raysplat::usd::convert(stage, &rss, &Default::default()).unwrap();
    let scene = raysplat::usd::load_scene(&rss).unwrap();
    // the sun travels down and toward −X at LIGHT_DEG from −Y
    let l = LIGHT_DEG.to_radians();
    let sun = scene.lights.iter().find_map(|l| if let raysplat::scene::Light::Distant { direction, .. } = l { Some(Vec3::from(*direction)) } else { None });
    assert!(sun.is_some_and(|d| (d - Vec3::new(-l.sin(), -l.cos(), 0.0)).length() < 1e-5), "{sun:?}");
    let s = RenderSettings { method: MethodSettings::Pt, spp, seed: 3, resolution: Some([size, size]), texture_filter: filter, ..Default::default() };
    render(scene, &s, &SilentProgress).unwrap().film
}

/// Mean beauty R over the image's central quarter.
fn centre(f: &Film) -> f32 {
    let rgb = f.rgb("").unwrap();
    let (w, h) = (f.width as usize, f.height as usize);
    let mut sum = 0.0;
    let mut n = 0;
    for y in h / 4..3 * h / 4 {
        for x in w / 4..3 * w / 4 {
            sum += rgb[3 * (y * w + x)];
            n += 1;
        }
    }
    sum / n as f32
}

/// A Lambertian plane (MaterialX standard_surface, specular 0) whose normal map tilts the normal
/// 30° toward a light 80° from the plane's normal: seen from straight above, its radiance is
/// `ρ E cos(80° − 30°) / π`, where the plane without the map gives `ρ E cos 80° / π`.
#[test]
fn a_normal_map_turns_a_plane_toward_a_grazing_light() {
    let dir = tempfile::tempdir().unwrap();
    let above = Vec3::new(0.0, 3.0, 0.0001);
    let mapped = centre(&pt(&stage(dir.path(), Look::MtlxNormalMap, 0.0, TILT_DEG, above, ""), 4, 16, TextureFilter::default()));
    let plain = centre(&pt(&stage(dir.path(), Look::MtlxPlain, 0.0, TILT_DEG, above, ""), 4, 16, TextureFilter::default()));
    let want = |deg: f32| ALBEDO * deg.to_radians().cos() / std::f32::consts::PI;
    eprintln!("normal-mapped {mapped:.5} (analytic {:.5}), plain {plain:.5} (analytic {:.5})", want(LIGHT_DEG - TILT_DEG), want(LIGHT_DEG));
    assert!((plain - want(LIGHT_DEG)).abs() < 0.005 * want(LIGHT_DEG), "plain {plain}");
    assert!((mapped - want(LIGHT_DEG - TILT_DEG)).abs() < 0.005 * want(LIGHT_DEG - TILT_DEG), "mapped {mapped}");
}

/// A UsdPreviewSurface normal map shades a flat plane as the plane turned by the same angle
/// (same view, same light, same BSDF in the same shading frame): the two agree.
#[test]
fn a_preview_surface_normal_map_equals_turned_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let above = Vec3::new(0.0, 3.0, 0.0001);
    let mapped = centre(&pt(&stage(dir.path(), Look::PreviewNormalMap, 0.0, TILT_DEG, above, ""), 16, 16, TextureFilter::default()));
    let turned = centre(&pt(&stage(dir.path(), Look::PreviewPlain, TILT_DEG, 0.0, above, ""), 16, 16, TextureFilter::default()));
    let flat = centre(&pt(&stage(dir.path(), Look::PreviewPlain, 0.0, 0.0, above, ""), 16, 16, TextureFilter::default()));
    eprintln!("mapped {mapped:.5}, turned {turned:.5}, flat {flat:.5}");
    assert!((mapped - turned).abs() < 0.01 * turned, "mapped {mapped} vs turned {turned}");
    assert!(turned > 2.0 * flat);
}

/// Seen at 85° from its normal, a plane whose normal map tilts the normal 30° away from the
/// viewer would reflect the view into the surface (every pixel black); the shading normal bends
/// back just enough, and the plane is lit.
#[test]
fn grazing_views_of_normal_maps_are_not_black() {
    let dir = tempfile::tempdir().unwrap();
    let v = 85f32.to_radians();
    // the viewer on the −X side; the map tilts toward +X, away from it
    let eye = Vec3::new(-3.0 * v.sin(), 3.0 * v.cos(), 0.0001);
    let f = pt(&stage(dir.path(), Look::MtlxNormalMap, 0.0, TILT_DEG, eye, ""), 4, 16, TextureFilter::default());
    let rgb = f.rgb("").unwrap();
    let (w, h) = (f.width as usize, f.height as usize);
    let black = (h / 4..3 * h / 4).flat_map(|y| (w / 4..3 * w / 4).map(move |x| (x, y))).filter(|&(x, y)| rgb[3 * (y * w + x)] <= 0.0).count();
    eprintln!("grazing view: centre {:.5}, {black} black pixels", centre(&f));
    assert_eq!(black, 0);
    assert!(centre(&f) > 0.01);
}

/// The camera's exposure (`exposure`, `exposure:iso`, `exposure:time`, `exposure:fStop`,
/// `exposure:responsivity`) multiplies the image's radiance by USD's linear exposure scale
/// `2^exposure · time · iso / 100 / fStop² · responsivity`; the albedo stays.
#[test]
fn the_camera_exposure_scales_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let above = Vec3::new(0.0, 3.0, 0.0001);
    let plain = pt(&stage(dir.path(), Look::PreviewPlain, 0.0, 0.0, above, ""), 2, 8, TextureFilter::default());
    let exposed = "float exposure = 0.5\n    float exposure:iso = 400\n    float exposure:time = 0.5\n    float exposure:fStop = 2\n    float exposure:responsivity = 1.5";
    let k = 0.5f32.exp2() * 0.5 * 400.0 / 100.0 / 4.0 * 1.5;
    let scaled = pt(&stage(dir.path(), Look::PreviewPlain, 0.0, 0.0, above, exposed), 2, 8, TextureFilter::default());
    for layer in ["", "direct", "indirect"] {
        let (a, b) = (plain.rgb(layer).unwrap(), scaled.rgb(layer).unwrap());
        for (x, y) in a.iter().zip(&b) {
            assert!((y - x * k).abs() <= 1e-6 * (x * k).abs().max(1e-6), "{layer}: {y} vs {x} × {k}");
        }
    }
    assert_eq!(plain.rgb("albedo"), scaled.rgb("albedo"));
}

/// A 100 m floor with a checkerboard (squares of 8 texels, 256² texels tiled 16 times, linear 0.05
/// and 0.9) under a light from above, seen from `eye` toward `target`.
fn checker_floor(dir: &Path, eye: Vec3, target: Vec3, fov_deg: f32) -> SceneDesc {
    let png = dir.join("checker.png");
    image::RgbImage::from_fn(256, 256, |x, y| if (x / 8 + y / 8) % 2 == 0 { image::Rgb([230, 230, 230]) } else { image::Rgb([13, 13, 13]) }).save(&png).unwrap();
    let tex = TextureDesc { path: png.display().to_string(), color_space: "raw".into(), st_transform: [[16.0, 0.0, 0.0], [0.0, 16.0, 0.0]], ..TextureDesc::default() };
    SceneDesc {
        meshes: vec![floor("/Floor", 50.0, 0)],
        instances: vec![place(0, "/Floor")],
        materials: vec![Material::Lambert { name: "/Looks/Checker".into(), diffuse_color: TexturedColor { value: [0.5; 3], texture: Some(0), vertex: false }, emissive_color: TexturedColor::constant([0.0; 3]) }],
        textures: vec![tex],
        lights: vec![Light::Distant { name: "/Sun".into(), direction: [0.0, -1.0, 0.0], angle_deg: 0.0, irradiance: [3.0; 3] }],
        camera: camera_looking(eye, target, fov_deg),
        source: "checker floor (built in code)".into(),
        ..Default::default()
    }
}

fn render_checker(scene: &SceneDesc, spp: u32, size: [u32; 2], filter: TextureFilter) -> Vec<f32> {
    let s = RenderSettings { method: MethodSettings::Pt, spp, seed: 11, resolution: Some(size), texture_filter: filter, ..Default::default() };
    render(scene.clone(), &s, &SilentProgress).unwrap().film.rgb("").unwrap()
}

/// Close up, where every texel covers several pixels, MIP filtering changes nothing: the image
/// is the bilinear one, bit for bit (texels stay as sharp).
#[test]
fn close_up_texels_stay_sharp() {
    let dir = tempfile::tempdir().unwrap();
    let scene = checker_floor(dir.path(), Vec3::new(0.0, 0.3, 0.0), Vec3::new(0.0, 0.0, -0.05), 20.0);
    let size = [32, 32];
    let bilinear = render_checker(&scene, 2, size, TextureFilter::Bilinear);
    for filter in [TextureFilter::Trilinear, TextureFilter::Anisotropic] {
        assert!(render_checker(&scene, 2, size, filter) == bilinear, "{filter:?} changed a close-up");
    }
    // and the checkerboard is there: dark and bright pixels
    let (lo, hi) = bilinear.iter().fold((f32::MAX, 0.0f32), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi > 10.0 * lo, "{lo} {hi}");
}

/// A checkerboard to the horizon at one sample per pixel: filtered lookups are nearer the
/// converged (bilinear, 256 samples per pixel) image than bilinear lookups, whose distant
/// pixels pick single texels.
#[test]
fn distant_checkerboards_converge_with_fewer_samples() {
    let dir = tempfile::tempdir().unwrap();
    let scene = checker_floor(dir.path(), Vec3::new(0.0, 1.5, 0.0), Vec3::new(0.0, 0.0, -30.0), 40.0);
    let size = [64, 32];
    let reference = render_checker(&scene, 256, size, TextureFilter::Bilinear);
    let rmse = |img: &[f32]| (img.iter().zip(&reference).map(|(a, b)| ((a - b) as f64).powi(2)).sum::<f64>() / img.len() as f64).sqrt();
    let errors: Vec<f64> = [TextureFilter::Bilinear, TextureFilter::Trilinear, TextureFilter::Anisotropic].iter().map(|&f| rmse(&render_checker(&scene, 1, size, f))).collect();
    eprintln!("rmse at 1 spp against 256 spp bilinear: bilinear {:.4}, trilinear {:.4}, anisotropic {:.4}", errors[0], errors[1], errors[2]);
    assert!(errors[2] < 0.8 * errors[0] && errors[1] < errors[0], "{errors:?}");
}
