use super::*;

#[test]
fn sphere_arguments_read_kind_place_and_radius_and_refuse_the_rest() {
    let parse = |s: &str| s.parse::<SphereArg>();
    assert_eq!(parse("chrome"), Ok(SphereArg { kind: SphereKind::Chrome, centre: None, radius: None }));
    assert_eq!(
        parse("diffuse@1,2,-0.5"),
        Ok(SphereArg { kind: SphereKind::Diffuse, centre: Some([1.0, 2.0, -0.5]), radius: None })
    );
    assert_eq!(
        parse("chrome@1,2,3,0.25"),
        Ok(SphereArg { kind: SphereKind::Chrome, centre: Some([1.0, 2.0, 3.0]), radius: Some(0.25) })
    );
    for bad in ["glass", "chrome@1,2", "chrome@1,2,3,-1", "chrome@1,x,3", "chrome@1,2,NaN"] {
        assert!(parse(bad).is_err(), "{bad} accepted");
    }
}

#[test]
fn spheres_without_a_place_fill_the_default_places_and_overlaps_are_refused() {
    let chrome = SphereArg { kind: SphereKind::Chrome, centre: None, radius: None };
    let four = place_spheres(&[chrome; 4]).unwrap();
    assert_eq!(four.iter().map(|s| s.centre).collect::<Vec<_>>(), DEFAULT_PLACES.to_vec());
    assert!(four.iter().all(|s| s.radius == DEFAULT_RADIUS));
    assert!(place_spheres(&[chrome; 5]).unwrap_err().contains("free default places"));
    // A sphere given a default place's spot pushes the placeless ones on to the next place.
    let here = SphereArg { kind: SphereKind::Diffuse, centre: Some(DEFAULT_PLACES[0]), radius: Some(0.1) };
    let two = place_spheres(&[chrome, here]).unwrap();
    assert_eq!(two[0].centre, DEFAULT_PLACES[1]);
    let there = SphereArg { centre: Some([0.0, 0.0, 0.0]), ..here };
    let close = SphereArg { centre: Some([0.1, 0.0, 0.0]), ..here };
    assert!(place_spheres(&[there, close]).unwrap_err().contains("overlap"));
}

#[test]
fn spheres_join_a_scene_with_their_reserved_materials() {
    let scene = r#"
[camera]
position = [0.0, -4.0, 0.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
width = 16
height = 16

[materials.white]
type = "lambertian"
albedo = [0.5, 0.5, 0.5]

[[shapes]]
type = "sphere"
material = "white"

[[lights]]
type = "directional"
direction = [0.0, -1.0, 1.0]
irradiance = [1.0, 1.0, 1.0]
"#;
    let spheres = place_spheres(&[
        SphereArg { kind: SphereKind::Chrome, centre: None, radius: None },
        SphereArg { kind: SphereKind::Diffuse, centre: None, radius: Some(0.3) },
    ])
    .unwrap();
    let text = add_to_scene(scene, &spheres).unwrap();
    let loaded = lucid_trace::parse_scene(&text, std::path::Path::new("scene.toml")).unwrap();
    assert_eq!(loaded.scene.materials.len(), 3);
    assert!(loaded.scene.materials.iter().any(|m| matches!(m, lucid_trace::Material::Conductor { .. })));
    let twice = add_to_scene(&text, &spheres).unwrap_err();
    assert!(twice.contains(CHROME_MATERIAL), "{twice}");
}
