//! Analytic tests of the parametric assets and user meshes (`osiris_models::environment::assets`).

use glam::DVec3;
use osiris_models::environment::assets::geometry::{
    components, euler_characteristic, is_closed, part_area, signed_volume, submesh, triangle_area,
    triangle_normal,
};
use osiris_models::environment::assets::{
    AssetError, AssetKind, AssetRef, ParamValue, build_asset, catalogue_markdown, load_user_mesh,
};
use osiris_models::environment::material::MaterialDb;
use osiris_models::environment::mesh::Mesh;

fn build(reference: &str, dims: Option<[f64; 3]>) -> Mesh {
    let a = AssetRef::parse(reference).unwrap_or_else(|e| panic!("{reference}: {e}"));
    build_asset(&a, dims.map(DVec3::from_array)).unwrap_or_else(|e| panic!("{reference}: {e}"))
}

fn bounds(m: &Mesh) -> (DVec3, DVec3) {
    let (lo, hi) = m.bounds().expect("non-empty mesh");
    (lo.as_dvec3(), hi.as_dvec3())
}

/// Every component closed, outward (positive volume) and of genus 0 or 1 (rings).
fn assert_closed_outward(name: &str, m: &Mesh) {
    assert!(is_closed(m), "{name}: not closed / inconsistently oriented");
    assert!(signed_volume(m) > 0.0, "{name}: negative volume");
    let mut chi_sum = 0;
    for c in components(m) {
        let s = submesh(m, &c);
        let v = signed_volume(&s);
        assert!(v > 0.0, "{name}: a component has volume {v}");
        let chi = euler_characteristic(&s);
        assert!(
            chi == 2 || chi == 0,
            "{name}: component with Euler characteristic {chi}"
        );
        chi_sum += chi;
    }
    assert_eq!(euler_characteristic(m), chi_sum, "{name}");
}

const ALL_BUILTIN: [&str; 13] = [
    "osiris:car",
    "osiris:van",
    "osiris:truck",
    "osiris:bus",
    "osiris:pedestrian",
    "osiris:cyclist",
    "osiris:motorcycle",
    "osiris:guardrail",
    "osiris:pole",
    "osiris:cone",
    "osiris:trihedral",
    "osiris:board",
    "osiris:box",
];

#[test]
fn every_builtin_asset_is_closed_and_outward() {
    for r in ALL_BUILTIN {
        for dims in [None, Some([2.0, 1.0, 1.5])] {
            let m = build(r, dims);
            assert!(m.triangle_count() > 0, "{r}");
            assert_eq!(m.triangle_part.len(), m.triangle_count());
            assert!(
                m.triangle_part
                    .iter()
                    .all(|&p| (p as usize) < m.parts.len())
            );
            assert_closed_outward(r, &m);
        }
    }
    // Variants.
    for r in [
        "osiris:guardrail?face=both",
        "osiris:guardrail?face=right&post_spacing_m=4",
        "osiris:pedestrian?pose=standing",
        "osiris:cone?bands=3",
        "osiris:trihedral?edge_m=0.5&thickness_m=0.01",
    ] {
        assert_closed_outward(r, &build(r, Some([3.0, 0.4, 1.2])));
    }
}

#[test]
fn genus_zero_assets_have_euler_characteristic_two_per_component() {
    for r in [
        "osiris:pedestrian",
        "osiris:guardrail",
        "osiris:pole",
        "osiris:cone",
        "osiris:trihedral",
        "osiris:board",
        "osiris:box",
    ] {
        let m = build(r, None);
        assert_eq!(
            euler_characteristic(&m),
            2 * components(&m).len() as i64,
            "{r}"
        );
    }
    // Tyres (and bicycle rims) are tori (genus 1): χ = 2·(components − rings).
    for (r, expected) in [
        ("osiris:cyclist", 4),
        ("osiris:car", 4),
        ("osiris:van", 4),
        ("osiris:bus", 4),
        ("osiris:truck", 6),
    ] {
        let m = build(r, None);
        let chi: Vec<i64> = components(&m)
            .iter()
            .map(|c| euler_characteristic(&submesh(&m, c)))
            .collect();
        let rings = chi.iter().filter(|&&x| x == 0).count();
        assert_eq!(rings, expected, "{r}: tyres (and rims)");
        assert_eq!(
            euler_characteristic(&m),
            2 * (chi.len() - rings) as i64,
            "{r}"
        );
    }
}

#[test]
fn stretched_assets_fill_their_osi_box_and_have_every_part() {
    let cases: [(&str, [f64; 3]); 10] = [
        ("osiris:car", [4.5, 1.8, 1.5]),
        ("osiris:car?paint=black", [4.8, 1.9, 1.45]),
        ("osiris:van", [5.4, 2.0, 2.3]),
        ("osiris:truck", [10.0, 2.55, 3.6]),
        ("osiris:bus", [12.0, 2.55, 3.2]),
        ("osiris:pedestrian", [0.5, 0.6, 1.8]),
        ("osiris:cyclist", [1.8, 0.6, 1.75]),
        ("osiris:motorcycle", [2.2, 0.8, 1.4]),
        ("osiris:pole", [0.1, 0.1, 3.0]),
        ("osiris:cone", [0.3, 0.3, 0.5]),
    ];
    for (r, d) in cases {
        let d = DVec3::from_array(d);
        let m = build(r, Some(d.to_array()));
        let (lo, hi) = bounds(&m);
        assert!(
            (lo + d * 0.5).abs().max_element() < 1e-3 && (hi - d * 0.5).abs().max_element() < 1e-3,
            "{r}: bounds {lo} .. {hi} for the box {d}"
        );
        // Without a dimension: the default size.
        let dd = AssetRef::parse(r).unwrap().kind.default_dimensions();
        let (lo, hi) = bounds(&build(r, None));
        assert!((hi - lo - dd).abs().max_element() < 1e-3, "{r}");
        // Every part of the spec is present with triangles.
        let kind = AssetRef::parse(r).unwrap().kind;
        for p in kind.spec().parts {
            assert!(
                part_area(&m, p.name) > 0.0,
                "{r}: part `{}` missing",
                p.name
            );
        }
    }
}

#[test]
fn car_parts_and_materials() {
    let m = build("osiris:car?paint=black", Some([4.5, 1.8, 1.5]));
    let material = |part: &str| {
        m.parts
            .iter()
            .find(|p| p.name == part)
            .map(|p| p.material.as_str())
    };
    assert_eq!(material("body"), Some("car_paint_black"));
    assert_eq!(material("glass"), Some("glass"));
    assert_eq!(material("wheels"), Some("rubber"));
    assert_eq!(material("bumpers"), Some("plastic_black"));
    assert_eq!(material("head_lamps"), Some("polycarbonate"));
    assert_eq!(material("tail_lamps"), Some("polycarbonate"));
    assert_eq!(material("licence_plates"), Some("retroreflective_sheeting"));
    // Paint by material name.
    let m2 = build("osiris:car?paint=aluminium", None);
    assert_eq!(m2.parts[0].material, "aluminium");
    // Head lamps face forward, tail lamps backward; the plates are 520 × 110 mm (the outer faces).
    let faces = |part: &str, dir: DVec3| -> f64 {
        let p = m.parts.iter().position(|q| q.name == part).unwrap() as u16;
        (0..m.triangle_count())
            .filter(|&i| m.triangle_part[i] == p && triangle_normal(&m, i).dot(dir) > 0.999)
            .map(|i| triangle_area(&m, i))
            .sum()
    };
    assert!(faces("head_lamps", DVec3::X) > 0.0 && faces("tail_lamps", -DVec3::X) > 0.0);
    // Both plates have a +x face (the rear plate's is hidden in the body): 2 × 520 × 110 mm.
    let plates = faces("licence_plates", DVec3::X);
    assert!(
        (plates - 2.0 * 0.52 * 0.11).abs() < 1e-3 * 0.1144,
        "plate area {plates}"
    );
    // The glass is seen from outside: windscreen normal points forward and up.
    assert!(faces("glass", DVec3::new(1.0, 0.0, 1.0).normalize()) == 0.0); // not exactly 45°
    let glass = m.parts.iter().position(|q| q.name == "glass").unwrap() as u16;
    assert!((0..m.triangle_count()).any(|i| {
        let n = triangle_normal(&m, i);
        m.triangle_part[i] == glass && n.x > 0.5 && n.z > 0.3
    }));
    // Wheels: ≥ 12 segments (16) and touching the ground.
    let (lo, _) = bounds(&m);
    let wheels = m.parts.iter().position(|q| q.name == "wheels").unwrap() as u16;
    let wheel_bottom = (0..m.triangle_count())
        .filter(|&i| m.triangle_part[i] == wheels)
        .flat_map(|i| m.triangle(i))
        .map(|p| p.z)
        .fold(f32::INFINITY, f32::min);
    assert!((f64::from(wheel_bottom) - lo.z).abs() < 1e-3);
}

#[test]
fn board_faces_plus_x_with_area_w_times_h() {
    for (r, w, h) in [
        (
            "osiris:board?width_m=1&height_m=1&material=lambertian_50",
            1.0,
            1.0,
        ),
        (
            "osiris:board?width_m=0.6&height_m=0.9&thickness_m=0.03",
            0.6,
            0.9,
        ),
        (
            "osiris:board?width_m=2&height_m=0.5&thickness_m=0",
            2.0,
            0.5,
        ),
    ] {
        let m = build(r, None);
        let face = m.parts.iter().position(|p| p.name == "face").unwrap() as u16;
        let mut area = 0.0;
        for i in 0..m.triangle_count() {
            if m.triangle_part[i] == face {
                assert!((triangle_normal(&m, i) - DVec3::X).length() < 1e-6, "{r}");
                area += triangle_area(&m, i);
            }
        }
        assert!((area - w * h).abs() < 1e-6, "{r}: face area {area}");
        let (lo, hi) = bounds(&m);
        assert!(
            (hi.y - lo.y - w).abs() < 1e-6 && (hi.z - lo.z - h).abs() < 1e-6,
            "{r}"
        );
    }
    // The face material is the parameter; the back defaults to it.
    let m = build("osiris:board?material=lambertian_10", None);
    assert!(m.parts.iter().all(|p| p.material == "lambertian_10"));
    let m = build("osiris:board?material=lambertian_10&back=wood", None);
    assert_eq!(
        m.parts.iter().find(|p| p.name == "back").unwrap().material,
        "wood"
    );
    // Thin board open (no thickness) vs closed.
    assert!(!is_closed(&build("osiris:board?thickness_m=0", None)));
    // The scenario's board: 0.05 × 1 × 1 OSI box, exactly the board.
    let m = build(
        "osiris:board?width_m=1&height_m=1&material=lambertian_50",
        Some([0.05, 1.0, 1.0]),
    );
    let (lo, hi) = bounds(&m);
    assert!((hi - lo - DVec3::new(0.05, 1.0, 1.0)).abs().max_element() < 1e-6);
    assert!(!m.parts.iter().any(|p| p.name == "mount"));
    // Taller OSI box: the board at the top, a post down to the box bottom.
    let m = build("osiris:board?width_m=1&height_m=1", Some([0.2, 1.0, 2.0]));
    let (lo, hi) = bounds(&m);
    assert!((lo.z + 1.0).abs() < 1e-6 && (hi.z - 1.0).abs() < 1e-6);
    assert!(part_area(&m, "mount") > 0.0);
    let face = m.parts.iter().position(|p| p.name == "face").unwrap() as u16;
    let face_z: Vec<f32> = (0..m.triangle_count())
        .filter(|&i| m.triangle_part[i] == face)
        .flat_map(|i| m.triangle(i))
        .map(|p| p.z)
        .collect();
    assert!(
        face_z.iter().all(|&z| z >= -1e-6),
        "the face is the top metre"
    );
}

#[test]
fn trihedral_plates_are_orthogonal_triangles_with_boresight_plus_x() {
    for a in [0.1, 0.05, 0.3] {
        let m = build(&format!("osiris:trihedral?edge_m={a}"), None);
        // The reflecting faces: triangles of area a²/2 whose normal makes the same angle with +x.
        let inner: Vec<usize> = (0..m.triangle_count())
            .filter(|&i| {
                (triangle_area(&m, i) - 0.5 * a * a).abs() < 1e-6
                    && (triangle_normal(&m, i).x - 1.0 / 3f64.sqrt()).abs() < 1e-5
            })
            .collect();
        assert_eq!(inner.len(), 3, "edge {a}");
        let n: Vec<DVec3> = inner.iter().map(|&i| triangle_normal(&m, i)).collect();
        // Mutually orthogonal, equal positive x components, boresight (sum of normals) along +x.
        for i in 0..3 {
            for j in i + 1..3 {
                assert!(n[i].dot(n[j]).abs() < 1e-5);
            }
            assert!((n[i].x - n[0].x).abs() < 1e-6 && n[i].x > 0.0);
        }
        let boresight = (n[0] + n[1] + n[2]).normalize();
        assert!((boresight - DVec3::X).length() < 1e-5);
        // Edge length a: the three triangles share the inner corner; each edge from it is a long.
        let tris: Vec<[DVec3; 3]> = inner
            .iter()
            .map(|&i| m.triangle(i).map(|p| p.as_dvec3()))
            .collect();
        let corner = tris[0]
            .iter()
            .copied()
            .find(|c| tris.iter().all(|t| t.iter().any(|p| p.distance(*c) < 1e-6)))
            .expect("a common corner");
        for t in &tris {
            let others: Vec<DVec3> = t
                .iter()
                .copied()
                .filter(|p| p.distance(corner) > 1e-6)
                .collect();
            assert_eq!(others.len(), 2);
            for o in &others {
                assert!((o.distance(corner) - a).abs() < 1e-5);
                // The aperture faces +x: the corner is at the back.
                assert!(o.x > corner.x);
            }
            assert!((others[0].distance(others[1]) - a * 2f64.sqrt()).abs() < 1e-5);
        }
        assert_eq!(
            m.parts
                .iter()
                .find(|p| p.name == "plates")
                .unwrap()
                .material,
            "aluminium"
        );
    }
    // Not scaled by the OSI box; a taller box gets a post and the reflector at its top.
    let m = build("osiris:trihedral?edge_m=0.1", Some([0.15, 0.15, 1.15]));
    let (lo, hi) = bounds(&m);
    assert!((lo.z + 0.575).abs() < 1e-6 && (hi.z - 0.575).abs() < 1e-6);
    assert!(part_area(&m, "mount") > 0.0);
    let plates = m.parts.iter().position(|p| p.name == "plates").unwrap() as u16;
    let pz: Vec<f32> = (0..m.triangle_count())
        .filter(|&i| m.triangle_part[i] == plates)
        .flat_map(|i| m.triangle(i))
        .map(|p| p.z)
        .collect();
    let extent =
        pz.iter().copied().fold(f32::MIN, f32::max) - pz.iter().copied().fold(f32::MAX, f32::min);
    assert!(f64::from(extent) < 0.2, "the reflector keeps its size");
    let m = build(
        "osiris:trihedral?edge_m=0.1&mount=none",
        Some([0.15, 0.15, 1.15]),
    );
    assert!(!m.parts.iter().any(|p| p.name == "mount"));
}

#[test]
fn guardrail_length_posts_and_height() {
    let m = build("osiris:guardrail", Some([400.0, 0.3, 0.75]));
    let (lo, hi) = bounds(&m);
    assert!((hi - lo - DVec3::new(400.0, 0.3, 0.75)).abs().max_element() < 1e-3);
    // Beam: top at the box top, facing +y (its front plane is the box side).
    let beam = m.parts.iter().position(|p| p.name == "beam").unwrap() as u16;
    let bz: Vec<DVec3> = (0..m.triangle_count())
        .filter(|&i| m.triangle_part[i] == beam)
        .flat_map(|i| m.triangle(i))
        .map(|p| p.as_dvec3())
        .collect();
    assert!((bz.iter().map(|p| p.z).fold(f64::MIN, f64::max) - 0.375).abs() < 1e-4);
    assert!((bz.iter().map(|p| p.y).fold(f64::MIN, f64::max) - 0.15).abs() < 1e-4);
    // 200 posts (2 m spacing) with spacers: 400 boxes = 400 closed components besides the beam.
    assert_eq!(components(&m).len(), 401);
    // Facing right: the beam on the −y side.
    let m = build("osiris:guardrail?face=right", Some([10.0, 0.3, 0.75]));
    let beam = m.parts.iter().position(|p| p.name == "beam").unwrap() as u16;
    let ymin = (0..m.triangle_count())
        .filter(|&i| m.triangle_part[i] == beam)
        .flat_map(|i| m.triangle(i))
        .map(|p| p.y)
        .fold(f32::MAX, f32::min);
    assert!((f64::from(ymin) + 0.15).abs() < 1e-4);
}

#[test]
fn model_reference_parsing() {
    // Percent-encoding, aliases, canonical form.
    let a = AssetRef::parse("osiris:board?width_m=1&height_m=1&material=lambertian%5F50").unwrap();
    assert_eq!(a.kind, AssetKind::Board);
    assert_eq!(a.text("material").as_deref(), Some("lambertian_50"));
    assert_eq!(a.number("width_m"), Some(1.0));
    assert_eq!(
        a.to_string(),
        "osiris:board?height_m=1&material=lambertian_50&width_m=1"
    );
    assert_eq!(AssetRef::parse(&a.to_string()).unwrap(), a);
    let c = AssetRef::parse("OSIRIS:car?paint=black&&").unwrap();
    assert_eq!(c.text("paint").as_deref(), Some("car_paint_black"));
    assert_eq!(
        AssetRef::parse("osiris:car")
            .unwrap()
            .text("paint")
            .as_deref(),
        Some("car_paint_white")
    );
    assert_eq!(
        AssetRef::parse("osiris:trihedral")
            .unwrap()
            .number("edge_m"),
        Some(0.1)
    );
    // User meshes: plain path, with params, file URI, osiris:mesh with an encoded path.
    let m = AssetRef::parse("models/mirror_L.glb").unwrap();
    assert_eq!(m.kind, AssetKind::Mesh);
    assert_eq!(m.path().unwrap().to_str(), Some("models/mirror_L.glb"));
    let m = AssetRef::parse("car.OBJ?material=steel&scale=0.001").unwrap();
    assert_eq!(m.text("material").as_deref(), Some("steel"));
    assert_eq!(m.number("scale"), Some(0.001));
    let m = AssetRef::parse("file:///data/my%20car.gltf").unwrap();
    assert_eq!(m.path().unwrap().to_str(), Some("/data/my car.gltf"));
    let m = AssetRef::parse("osiris:mesh?path=dir%20x/a%3Fb.obj&up=y").unwrap();
    assert_eq!(m.path().unwrap().to_str(), Some("dir x/a?b.obj"));
    assert_eq!(AssetRef::parse(&m.to_string()).unwrap(), m);
}

#[test]
fn parameter_errors_name_the_asset_and_parameter() {
    let err = |r: &str| AssetRef::parse(r).unwrap_err();
    let e = err("osiris:trihedral?edge_m=-0.1");
    assert!(
        matches!(
            &e,
            AssetError::InvalidParam {
                asset: "trihedral",
                param: "edge_m",
                ..
            }
        ),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("trihedral") && msg.contains("edge_m") && msg.contains("[0.005, 5] m"),
        "{msg}"
    );
    let e = err("osiris:car?colour=red");
    let msg = e.to_string();
    assert!(matches!(&e, AssetError::UnknownParam { asset: "car", .. }));
    assert!(
        msg.contains("colour") && msg.contains("paint") && msg.contains("length_m"),
        "{msg}"
    );
    let msg = err("osiris:car?paint=Red!").to_string();
    assert!(
        msg.contains("paint") && msg.contains("white, black or a material name"),
        "{msg}"
    );
    let msg = err("osiris:spaceship?x=1").to_string();
    assert!(
        msg.contains("spaceship") && msg.contains("car, van, truck") && msg.contains("trihedral"),
        "{msg}"
    );
    let msg = err("osiris:board?width_m=abc").to_string();
    assert!(
        msg.contains("width_m") && msg.contains("abc") && msg.contains("a number in"),
        "{msg}"
    );
    let msg = err("osiris:pole?segments=3").to_string();
    assert!(
        msg.contains("segments") && msg.contains("an integer in [6, 128]"),
        "{msg}"
    );
    let msg = err("osiris:guardrail?face=up").to_string();
    assert!(
        msg.contains("face") && msg.contains("left, right, both"),
        "{msg}"
    );
    assert!(matches!(
        err("osiris:car?paint=white&paint=black"),
        AssetError::DuplicateParam { .. }
    ));
    assert!(
        err("osiris:car?paint")
            .to_string()
            .contains("`paint` has no `=value`")
    );
    assert!(
        err("osiris:car?paint=%G1")
            .to_string()
            .contains("percent-encoding")
    );
    assert!(matches!(
        err("osiris:board?width_m=NaN"),
        AssetError::InvalidParam { .. }
    ));
    assert!(matches!(err("  "), AssetError::Empty));
    let msg = err("vehicles/audi.fbx").to_string();
    assert!(
        msg.contains("audi.fbx") && msg.contains(".obj, .gltf, .glb"),
        "{msg}"
    );
    assert!(matches!(
        err("osiris:mesh?material=steel"),
        AssetError::MissingParam { param: "path", .. }
    ));
    // Params after a path are validated against the mesh asset.
    assert!(
        err("car.obj?paint=white")
            .to_string()
            .contains("allowed: path, material, up")
    );
    // with(): programmatic parameters are validated the same way.
    assert!(
        AssetRef::builtin(AssetKind::Cone)
            .with("bands", "9")
            .is_err()
    );
    assert_eq!(
        AssetRef::builtin(AssetKind::Cone)
            .with("bands", "2")
            .unwrap()
            .given("bands"),
        Some(&ParamValue::Number(2.0))
    );
}

#[test]
fn sizing_parameters_override_the_osi_dimension() {
    let m = build("osiris:car?length_m=4&height_m=1.4", Some([5.0, 2.0, 1.6]));
    let (lo, hi) = bounds(&m);
    assert!((hi - lo - DVec3::new(4.0, 2.0, 1.4)).abs().max_element() < 1e-3);
    // Non-positive OSI components fall back to the default per axis.
    let m = build("osiris:car", Some([0.0, 2.0, -1.0]));
    let (lo, hi) = bounds(&m);
    assert!((hi - lo - DVec3::new(4.5, 2.0, 1.5)).abs().max_element() < 1e-3);
}

#[test]
fn builtin_materials_exist_in_the_database() {
    let mut db = MaterialDb::builtin();
    for r in ALL_BUILTIN.iter().chain(&[
        "osiris:motorcycle?clothing=cotton",
        "osiris:pole?material=concrete",
    ]) {
        for p in build(r, None).parts {
            assert!(
                db.resolve(&p.material).is_ok(),
                "{r}: part `{}` has unknown material `{}`",
                p.name,
                p.material
            );
        }
    }
}

#[test]
fn catalogue_lists_every_asset_and_parameter() {
    let md = catalogue_markdown();
    for k in AssetKind::ALL {
        assert!(md.contains(&format!("### `{}`", k.name())));
        for p in k.spec().params {
            assert!(md.contains(&format!("| `{}` |", p.name)));
        }
    }
}

#[test]
fn assets_md_tables_are_current() {
    // The tables in models/ASSETS.md (or, once merged, the README) are generated; regenerate them
    // with `catalogue_markdown()` after changing a spec.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let md = catalogue_markdown();
    let docs: Vec<String> = [root.join("ASSETS.md"), root.join("../README.md")]
        .iter()
        .filter_map(|p| std::fs::read_to_string(p).ok())
        .collect();
    assert!(
        docs.iter().any(|d| d.contains(&md)),
        "models/ASSETS.md is out of date: replace its generated part with catalogue_markdown()"
    );
}

// ---------------------------------------------------------------------------------------------------
// User meshes

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("osiris-assets-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const CUBE_OBJ: &str = "mtllib cube.mtl
v 0 0 0
v 2 0 0
v 2 1 0
v 0 1 0
v 0 0 1
v 2 0 1
v 2 1 1
v 0 1 1
usemtl Steel
f 1 4 3 2
f 5 6 7 8
usemtl MyPaint
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
";

#[test]
fn obj_user_mesh_with_material_mapping() {
    let dir = temp_dir("obj");
    std::fs::write(dir.join("cube.obj"), CUBE_OBJ).unwrap();
    std::fs::write(
        dir.join("cube.mtl"),
        "newmtl Steel\nKd 0.5 0.5 0.5\nnewmtl MyPaint\nKd 1 0 0\n",
    )
    .unwrap();
    let m = load_user_mesh(dir.join("cube.obj")).unwrap();
    assert_eq!(m.triangle_count(), 12);
    assert!(
        is_closed(&m) || m.positions.len() > 8,
        "tobj single_index may duplicate vertices"
    );
    assert!((signed_volume(&m) - 2.0).abs() < 1e-6);
    let (lo, hi) = bounds(&m);
    assert!(
        (lo + DVec3::new(1.0, 0.5, 0.5)).length() < 1e-6
            && (hi - DVec3::new(1.0, 0.5, 0.5)).length() < 1e-6
    );
    let mat = |n: &str| {
        m.parts
            .iter()
            .find(|p| p.name == n)
            .map(|p| p.material.clone())
    };
    assert_eq!(mat("Steel").as_deref(), Some("steel"));
    assert_eq!(mat("MyPaint").as_deref(), Some("lambertian_50"));
    // Through a reference: fallback material, stretch to the OSI box, mm → m.
    let r = format!(
        "{}?material=plastic_black&fit=stretch",
        dir.join("cube.obj").display()
    );
    let m = build(&r, Some([4.0, 2.0, 1.0]));
    assert_eq!(
        m.parts
            .iter()
            .find(|p| p.name == "MyPaint")
            .unwrap()
            .material,
        "plastic_black"
    );
    let (lo, hi) = bounds(&m);
    assert!((hi - lo - DVec3::new(4.0, 2.0, 1.0)).length() < 1e-6);
    let r = format!(
        "osiris:mesh?path={}&scale=0.001&fit=none",
        dir.join("cube.obj").display()
    );
    let (_, hi) = bounds(&build(&r, None));
    assert!((hi - DVec3::new(0.002, 0.001, 0.001)).length() < 1e-9);
    // Missing file: the error names it.
    let e = load_user_mesh(dir.join("missing.obj")).unwrap_err();
    assert!(e.to_string().contains("missing.obj"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                s.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A glTF with one triangle: file coordinates (1,0,0), (0,1,0), (0,0,2), material `glass`, under a
/// node translated by (0, 0, 10) in file coordinates.
fn gltf_json(uri: Option<&str>) -> (String, Vec<u8>) {
    let mut bin = Vec::new();
    for v in [1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    let buffer = match uri {
        Some(u) => format!(r#"{{"byteLength":36,"uri":"{u}"}}"#),
        None => r#"{"byteLength":36}"#.to_string(),
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0,"translation":[0,0,10]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
        "materials":[{{"name":"Glass"}}],
        "buffers":[{buffer}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,2]}}]}}"#
    );
    (json, bin)
}

#[test]
fn gltf_and_glb_user_meshes() {
    let dir = temp_dir("gltf");
    let (_, bin) = gltf_json(None);
    // Embedded data URI.
    let (json, _) = gltf_json(Some(&format!(
        "data:application/octet-stream;base64,{}",
        base64(&bin)
    )));
    std::fs::write(dir.join("tri.gltf"), &json).unwrap();
    // External buffer file.
    let (json_ext, _) = gltf_json(Some("tri.bin"));
    std::fs::write(dir.join("tri_ext.gltf"), &json_ext).unwrap();
    std::fs::write(dir.join("tri.bin"), &bin).unwrap();
    // GLB: header, JSON chunk (space-padded), BIN chunk.
    let (mut jg, _) = gltf_json(None);
    while jg.len() % 4 != 0 {
        jg.push(' ');
    }
    let mut glb = Vec::new();
    let total = 12 + 8 + jg.len() + 8 + bin.len();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(jg.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(jg.as_bytes());
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    std::fs::write(dir.join("tri.glb"), &glb).unwrap();

    for f in ["tri.gltf", "tri_ext.gltf", "tri.glb"] {
        // Keep the file origin: glTF (x left, y up, z forward) → osiris (z, x, y); node transform applied.
        let r = format!("osiris:mesh?path={}&fit=none", dir.join(f).display());
        let m = build(&r, None);
        assert_eq!(m.triangle_count(), 1, "{f}");
        let got: Vec<DVec3> = m.triangle(0).iter().map(|p| p.as_dvec3()).collect();
        let want = [
            DVec3::new(10.0, 1.0, 0.0),
            DVec3::new(10.0, 0.0, 1.0),
            DVec3::new(12.0, 0.0, 0.0),
        ];
        for (g, w) in got.iter().zip(want) {
            assert!(g.distance(w) < 1e-6, "{f}: {got:?}");
        }
        // Material name matched case-insensitively.
        assert_eq!(m.parts[0].name, "Glass");
        assert_eq!(m.parts[0].material, "glass");
        // The handedness is kept: the normal is the file normal mapped the same way.
        let n = triangle_normal(&m, 0);
        let nf = (DVec3::new(-1.0, 1.0, 0.0))
            .cross(DVec3::new(-1.0, 0.0, 2.0))
            .normalize(); // file frame
        assert!((n - DVec3::new(nf.z, nf.x, nf.y)).length() < 1e-6);
    }
    // A broken file names itself.
    std::fs::write(dir.join("bad.gltf"), "{ not json").unwrap();
    let e = load_user_mesh(dir.join("bad.gltf")).unwrap_err();
    assert!(
        e.to_string().contains("bad.gltf") && e.to_string().contains("invalid glTF"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
