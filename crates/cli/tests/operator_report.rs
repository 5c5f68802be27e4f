//! What the demo tells an operator (issue 40): the printed line and the
//! report's paragraph on its own F-vs-NP result, the report's glossary and
//! label-quality table, and progress in a log as timestamped lines.

mod common;

use common::{stderr, stdout, vpctl};

#[test]
fn sim_run_says_what_its_f_against_np_means_and_the_report_explains_its_columns() {
    let dir = tempfile::tempdir().unwrap();
    let o = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cfg = dir.path().join("virtual.toml");
    std::fs::write(
        &cfg,
        stdout(&o).replace("mvs = \"patchmatch\"", "mvs = \"virtual\""),
    )
    .unwrap();
    let out = dir.path().join("report");
    let o = vpctl(&[
        "sim",
        "run",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    // One line, made from this run's own F and NP rows.
    let line = text
        .lines()
        .find(|l| l.starts_with("F vs NP: "))
        .unwrap_or_else(|| panic!("no F vs NP line in:\n{text}"));
    assert!(
        line.contains("F1x2 f ") && line.contains("NP1x2 "),
        "{line}"
    );
    assert!(line.contains("docs/campaign-findings.md"), "{line}");
    let report = std::fs::read_to_string(out.join("report.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&report).unwrap();
    let f_of = |name: &str| {
        json["rows"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["strategy"] == name)
            .and_then(|r| r["f_mean"].as_f64())
            .unwrap()
    };
    let (f, np) = (f_of("F1x2"), f_of("NP1x2"));
    assert!(
        line.contains(&format!("F1x2 f {f:.1} % vs NP1x2 {np:.1} %")),
        "{line}"
    );
    let ahead = if f >= np { "F ahead" } else { "NP ahead" };
    assert!(line.contains(ahead), "{line}");

    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<dl id=\"glossary\">"), "no glossary");
    for term in ["cov", "f_res", "f_unc", "f"] {
        assert!(
            html.contains(&format!("<dt><code>{term}</code></dt>")),
            "{term} not explained"
        );
    }
    assert!(html.contains("<p id=\"f-vs-np\">"), "no F-vs-NP paragraph");
    assert!(
        html.contains("<table id=\"label-quality\">"),
        "label quality is not a table"
    );
    assert!(
        !html.contains("| material |"),
        "raw Markdown left in the page"
    );
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(md.contains("## F against NP on this run"), "{md}");

    // Progress in a log: timestamped lines, no terminal codes.
    let err = stderr(&o);
    for l in err.lines().filter(|l| !l.starts_with("warning")) {
        assert!(
            l.starts_with('[') && l.contains(" s] "),
            "no timestamp: {l}"
        );
    }
    assert!(!err.contains('\r') && !err.contains('\u{1b}'), "{err:?}");
}
