//! Tests of the campaign configuration (`mod.rs`).

use super::*;

/// Regression (found by the reader fuzzing of `tests/fuzz`): `nan` in a
/// campaign config became a JSON `null` on the way to the overrides and
/// was reported as "invalid type: null, expected f64", without a key.
/// Regression (found by the long fuzz run of `tests/fuzz`): an array
/// one element too long, which the TOML parse lets through, was
/// reported without its section.
#[test]
fn too_long_array_names_its_section() {
    let text = CampaignConfig::demo().to_toml().unwrap().replacen(
        "distance_m = [8.0, 20.0]",
        "distance_m = [80.0, 45.0, 20.0]",
        1,
    );
    assert!(text.contains("[80.0, 45.0, 20.0]"));
    let m = CampaignConfig::from_toml(&text, Path::new("c.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("c.toml") && m.contains("configuration: ["),
        "{m}"
    );
}

#[test]
fn nan_in_a_config_names_the_key() {
    let mut virt = CampaignConfig::demo();
    virt.mvs = MvsKind::Virtual;
    let text = virt
        .to_toml()
        .unwrap()
        .replacen("angles_deg = [0.0,", "angles_deg = [nan,", 1);
    assert!(text.contains("[nan,"));
    let e = CampaignConfig::from_toml(&text, Path::new("c.toml")).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("c.toml") && m.contains("angles_deg[0] = NaN: must be a finite number"),
        "{m}"
    );
}

#[test]
fn presets_round_trip_through_toml_and_validate() {
    for c in [
        CampaignConfig::demo(),
        CampaignConfig::paper(),
        CampaignConfig::quick(),
    ] {
        c.validate().unwrap();
        let text = c.to_toml().unwrap();
        let back = CampaignConfig::from_toml(&text, Path::new("x.toml")).unwrap();
        assert_eq!(back, c);
    }
    // An empty file is the demo.
    assert_eq!(
        CampaignConfig::from_toml("", Path::new("e.toml")).unwrap(),
        CampaignConfig::demo()
    );
}

#[test]
fn refuses_unknown_keys_and_training_on_the_held_out_site() {
    let e = CampaignConfig::from_toml("sed = 3\n", Path::new("typo.toml")).unwrap_err();
    let m = e.to_string();
    assert!(m.contains("typo.toml") && m.contains("sed"), "{m}");
    let e = CampaignConfig::from_toml(
        "held_out_seeds = [101]\n[training]\nsite_seeds = [101, 102]\n",
        Path::new("c.toml"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("never be a training site"), "{e}");
    let e =
        CampaignConfig::from_toml("strategies = [\"G5x4\"]\n", Path::new("s.toml")).unwrap_err();
    assert!(e.to_string().contains("G5x4"), "{e}");
}

#[test]
fn a_partial_section_keeps_the_demo_values_of_its_other_keys() {
    let c = CampaignConfig::from_toml(
        "[planner]\ngsd_m = 0.08\n[site]\nn_trees_at_rock = 3\n",
        Path::new("p.toml"),
    )
    .unwrap();
    let demo = CampaignConfig::demo();
    assert!((c.planner.gsd_m - 0.08).abs() < 1e-12);
    assert_eq!(c.planner.camera, demo.planner.camera);
    assert_eq!(c.planner.n_triangles, demo.planner.n_triangles);
    assert_eq!(c.site.n_trees_at_rock, 3);
    assert_eq!(c.site.target_faces, demo.site.target_faces);
    // A wrong type still names the line.
    let e =
        CampaignConfig::from_toml("[planner]\ngsd_m = \"x\"\n", Path::new("t.toml")).unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
}

/// Issue 34, item 6: the demo runs vp-mvs, and its printed config held the
/// virtual MVS's planted `[profile.*]` curves and `[gate]`, which a reader
/// takes for truth the run uses. They are written only with
/// `mvs = "virtual"`, and naming them beside another matcher is refused.
#[test]
fn the_virtual_mvs_sections_appear_only_where_it_runs() {
    let demo = CampaignConfig::demo();
    assert_eq!(demo.mvs, MvsKind::Patchmatch);
    let text = demo.to_toml().unwrap();
    let table: toml::Table = toml::from_str(&text).unwrap();
    for key in ["profile", "gate"] {
        assert!(!table.contains_key(key), "[{key}] in the demo's config");
    }
    assert!(table.contains_key("patchmatch"));
    // The other sections keep their order (that of the fields).
    let at = |h: &str| text.find(&format!("\n[{h}]\n")).unwrap();
    assert!(at("patchmatch.sgm") < at("render") && at("render") < at("training"));
    let mut virt = demo.clone();
    virt.mvs = MvsKind::Virtual;
    let table: toml::Table = toml::from_str(&virt.to_toml().unwrap()).unwrap();
    assert!(table.contains_key("profile") && table.contains_key("gate"));
    // Back from the file: the demo's values, whether written or not.
    assert_eq!(
        CampaignConfig::from_toml(&text, Path::new("d.toml")).unwrap(),
        demo
    );
    // Beside patchmatch or sgm, [profile] or [gate] is an error naming
    // the section, the matcher and the fix.
    let with_profile =
        virt.to_toml()
            .unwrap()
            .replacen("mvs = \"virtual\"", "mvs = \"patchmatch\"", 1);
    for (text, key) in [
        (with_profile.as_str(), "profile"),
        ("mvs = \"sgm\"\n[gate]\nenabled = false\n", "gate"),
    ] {
        let m = CampaignConfig::from_toml(text, Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            m.contains(&format!("p.toml: [{key}] configures the virtual MVS"))
                && m.contains("set mvs = \"virtual\""),
            "{m}"
        );
    }
    let over = serde_json::json!({ "gate": { "enabled": false } });
    assert!(demo.with_overrides(over.clone()).is_err());
    assert!(virt.with_overrides(over).is_ok());
    // With the virtual MVS they are read.
    let c = CampaignConfig::from_toml(
        "mvs = \"virtual\"\n[gate]\nenabled = false\n",
        Path::new("v.toml"),
    )
    .unwrap();
    assert!(!c.gate.enabled);
}
