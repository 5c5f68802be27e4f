//! Issue 39, item 6: every section of a campaign config refuses a key it
//! does not know, naming the file, the line, the column and the valid keys.
//! `[site]`, `[render]`, `[training.site]` and `[profile.*]` once took
//! `sizee = 3` silently and ran with the defaults.

use std::path::Path;

use super::CampaignConfig;

/// The dotted path of every table of `t` ("" for the top level).
fn tables(t: &toml::Table, path: &str, out: &mut Vec<(String, Vec<String>)>) {
    out.push((path.to_string(), t.keys().cloned().collect()));
    for (k, v) in t {
        if let toml::Value::Table(sub) = v {
            let p = if path.is_empty() {
                k.clone()
            } else {
                format!("{path}.{k}")
            };
            tables(sub, &p, out);
        }
    }
}

#[test]
fn every_section_refuses_an_unknown_key_with_line_column_and_valid_keys() {
    // The virtual MVS's sections are written only where it is chosen.
    let mut paper = CampaignConfig::paper();
    paper.mvs = super::MvsKind::Virtual;
    let full: toml::Table = toml::from_str(&paper.to_toml().unwrap()).unwrap();
    let mut all = Vec::new();
    tables(&full, "", &mut all);
    let paths: Vec<&str> = all.iter().map(|(p, _)| p.as_str()).collect();
    for must in [
        "site",
        "site.origin",
        "render",
        "training.site",
        "training.labels",
        "training.forest",
        "profile",
        "profile.ground",
        "planner.camera",
        "patchmatch",
        "surface",
    ] {
        assert!(paths.contains(&must), "no [{must}] in {paths:?}");
    }
    for (path, keys) in &all {
        let text = if path.is_empty() {
            "sizee = 3\n".to_string()
        } else {
            format!("[{path}]\nsizee = 3\n")
        };
        let line = if path.is_empty() { 1 } else { 2 };
        let m = CampaignConfig::from_toml(&text, Path::new("typo.toml"))
            .map(|_| ())
            .map_err(|e| e.to_string());
        let Err(m) = m else {
            panic!("[{path}] took `sizee = 3`");
        };
        assert!(
            m.starts_with(&format!(
                // serde says "expected `a` or `b`" for two keys, "one of" for more.
                "typo.toml: line {line}: column 1: unknown field `sizee`, expected "
            )),
            "[{path}]: {m}"
        );
        // The valid keys are listed (every key the section writes).
        for k in keys {
            assert!(
                m.contains(&format!("`{k}`")),
                "[{path}] does not list {k}: {m}"
            );
        }
    }
}
