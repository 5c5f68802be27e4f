//! Tests of the config reader (`config_file.rs`).

use super::*;

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct P {
    #[allow(dead_code)]
    a: f64,
}

#[test]
fn errors_name_file_line_and_column() {
    let e = parse_toml::<P>("a = 1.0\nb = 2\n", Path::new("p.toml")).unwrap_err();
    let m = e.to_string();
    assert!(
        m.starts_with("p.toml: line 2: column 1: unknown field `b`"),
        "{m}"
    );
    let e = parse_toml::<P>("a = \"x\"\n", Path::new("p.toml")).unwrap_err();
    assert!(e.to_string().contains("p.toml: line 1: column 5:"), "{e}");
}

#[test]
fn json_parameter_files_are_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("params.json");
    std::fs::write(&path, "{\"a\": 1.0}").unwrap();
    let m = load_toml::<P>(&path).unwrap_err().to_string();
    assert!(
        m.contains("params.json: line 1: this looks like JSON"),
        "{m}"
    );
}

/// A parameter type with its own defaults, for the section reader.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
struct Q {
    gsd_m: f64,
    width: u32,
    inner: Inner,
}

#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
struct Inner {
    k: Vec<f64>,
}

impl Default for Q {
    fn default() -> Self {
        Q {
            gsd_m: 0.01,
            width: 5472,
            inner: Inner::default(),
        }
    }
}

impl ConfigSection for Q {
    type Error = SceneError;
    fn check(&self, place: &str) -> Result<()> {
        if self.gsd_m > 0.0 {
            Ok(())
        } else {
            Err(SceneError::InvalidArgument(format!(
                "{place}: gsd_m = {}: must be > 0",
                self.gsd_m
            )))
        }
    }
}

const FILE: &str =
    "seed = 1\n[site]\nsize = 3.0\n[planner]\ngsd_m = 0.04\n[planner.inner]\nk = [1.0]\n";

#[test]
fn a_section_takes_its_types_defaults_for_missing_keys() {
    let q: Q = read_section(FILE, Path::new("c.toml"), "planner").unwrap();
    assert_eq!(
        q,
        Q {
            gsd_m: 0.04,
            width: 5472,
            inner: Inner { k: vec![1.0] },
        }
    );
    // An absent section is all defaults; a dotted path descends.
    let none: Q = read_section(FILE, Path::new("c.toml"), "eval").unwrap();
    assert_eq!(none, Q::default());
    let inner: Inner = parse_section(FILE, Path::new("c.toml"), "planner.inner")
        .unwrap()
        .unwrap();
    assert_eq!(inner.k, vec![1.0]);
    // The whole file as one section.
    let whole: Q = read_section("width = 9\n", Path::new("q.toml"), "").unwrap();
    assert_eq!((whole.width, whole.gsd_m), (9, 0.01));
}

#[test]
fn over_a_base_missing_keys_keep_the_bases_values() {
    let base = Q {
        gsd_m: 0.5,
        width: 240,
        inner: Inner { k: vec![7.0, 8.0] },
    };
    let q = read_section_over(&base, FILE, Path::new("c.toml"), "planner").unwrap();
    assert_eq!(
        (q.gsd_m, q.width, q.inner.k.clone()),
        (0.04, 240, vec![1.0])
    );
    let same = read_section_over(&base, FILE, Path::new("c.toml"), "eval").unwrap();
    assert_eq!(same, base);
    let m = read_section_over(&base, "[p]\ngsd_m = nan\n", Path::new("n.toml"), "p")
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("n.toml: p.gsd_m = NaN: must be a finite number"),
        "{m}"
    );
}

#[test]
fn unknown_keys_and_bad_values_name_file_line_section_and_key() {
    let text = "[planner]\ngsd_m = 0.04\nwidht = 3\n";
    let m = read_section::<Q>(text, Path::new("c.toml"), "planner")
        .unwrap_err()
        .to_string();
    assert!(
        m.starts_with("c.toml: line 3: column 1: unknown field `widht`")
            && m.ends_with("(in [planner])"),
        "{m}"
    );
    let text = "[planner]\n[planner.inner]\nj = 1\n";
    let m = read_section::<Q>(text, Path::new("c.toml"), "planner")
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("line 3") && m.contains("(in [planner.inner])"),
        "{m}"
    );
    // Keys of other sections are not this reader's business.
    assert!(read_section::<Q>("[site]\nwidht = 3\n", Path::new("c.toml"), "planner").is_ok());
    // The range check names the place.
    let m = read_section::<Q>("[planner]\ngsd_m = -1.0\n", Path::new("c.toml"), "planner")
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("c.toml: [planner]: gsd_m = -1: must be > 0"),
        "{m}"
    );
    // A multi-line array is not mistaken for a header.
    let text = "[planner.inner]\nk = [\n  1.0,\n]\nz = 1\n";
    let m = read_section::<Q>(text, Path::new("c.toml"), "planner")
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("line 5") && m.ends_with("(in [planner.inner])"),
        "{m}"
    );
}
