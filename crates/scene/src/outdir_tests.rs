use super::*;

fn write_files(dir: &Path, files: &[(&str, &str)]) -> Result<()> {
    for (name, text) in files {
        let p = dir.join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).map_err(|e| SceneError::io(parent, e))?;
        }
        std::fs::write(&p, text).map_err(|e| SceneError::io(&p, e))?;
    }
    Ok(())
}

fn names(dir: &Path) -> Vec<String> {
    let (files, _) = list_tree(dir).unwrap();
    files
}

fn refusal(e: &SceneError) -> String {
    assert!(matches!(e, SceneError::OutputRefused { .. }), "{e}");
    e.to_string()
}

#[test]
fn an_output_holding_an_input_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("model");
    std::fs::create_dir(&input).unwrap();
    for out in [tmp.path().to_path_buf(), input.clone(), input.join("..")] {
        let e = OutDir::check(&out, "colmap align", &[&input], true).unwrap_err();
        assert!(refusal(&e).contains("the input"), "{e}");
    }
    // Inside the input is fine (COLMAP's own layout puts dense/ there).
    assert!(OutDir::check(&input.join("dense"), "x", &[&input], false).is_ok());
}

#[test]
fn a_foreign_folder_is_refused_even_with_force() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("rep");
    write_files(&out, &[("thesis.tex", "mine")]).unwrap();
    let e = OutDir::check(&out, "demo", &[], true).unwrap_err();
    let m = refusal(&e);
    assert!(
        m.contains("not a vpctl output") && m.contains("--out"),
        "{m}"
    );
    // An empty folder is fine.
    std::fs::remove_file(out.join("thesis.tex")).unwrap();
    assert!(OutDir::check(&out, "demo", &[], false).is_ok());
}

#[test]
fn force_replaces_only_what_vpctl_wrote() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("rep");
    let od = OutDir::check(&out, "demo", &[], false).unwrap();
    od.write(|d| {
        write_files(
            d,
            &[
                ("table.md", "old"),
                ("plans/a.json", "a"),
                ("gone.csv", "x"),
            ],
        )
    })
    .unwrap();
    write_files(
        &out,
        &[("notes.txt", "precious"), ("plans/mine.txt", "also mine")],
    )
    .unwrap();
    // Without force: refused, untouched.
    let e = OutDir::check(&out, "demo", &[], false).unwrap_err();
    assert!(refusal(&e).contains("--force"), "{e}");
    let od = OutDir::check(&out, "demo", &[], true).unwrap();
    od.write(|d| write_files(d, &[("table.md", "new"), ("plans/a.json", "b")]))
        .unwrap();
    assert_eq!(
        names(&out),
        ["notes.txt", "plans/a.json", "plans/mine.txt", "table.md"]
    );
    assert_eq!(
        std::fs::read_to_string(out.join("table.md")).unwrap(),
        "new"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "precious"
    );
    let m = Manifest::load(&out).unwrap().unwrap();
    assert_eq!(m.files, ["plans/a.json", "table.md"]);
    // Nothing left beside it.
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 1);
}

#[test]
fn a_failed_write_leaves_the_old_output() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ws");
    let od = OutDir::check(&out, "sim fly", &[], false).unwrap();
    od.write(|d| write_files(d, &[("a.txt", "old")])).unwrap();
    let od = OutDir::check(&out, "sim fly", &[], true).unwrap();
    let r: Result<()> = od.write(|d| {
        write_files(d, &[("a.txt", "half")])?;
        Err(SceneError::InvalidArgument("boom".into()))
    });
    assert!(r.is_err());
    assert_eq!(std::fs::read_to_string(out.join("a.txt")).unwrap(), "old");
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 1);
}

#[test]
fn a_user_file_the_new_output_would_overwrite_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ws");
    let od = OutDir::check(&out, "predict", &[], false).unwrap();
    od.write(|d| write_files(d, &[("a.vpconf", "old")]))
        .unwrap();
    write_files(&out, &[("b.vpconf", "the user's")]).unwrap();
    let od = OutDir::check(&out, "predict", &[], true).unwrap();
    let e = od
        .write(|d| write_files(d, &[("a.vpconf", "new"), ("b.vpconf", "new")]))
        .unwrap_err();
    assert!(refusal(&e).contains("b.vpconf"), "{e}");
    assert_eq!(
        std::fs::read_to_string(out.join("a.vpconf")).unwrap(),
        "old"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("b.vpconf")).unwrap(),
        "the user's"
    );
}

#[test]
fn a_manifest_naming_paths_outside_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ws");
    write_files(
        &out,
        &[(
            MANIFEST_FILE,
            r#"{"command":"demo","version":"0","files":["../x"],"folders":[]}"#,
        )],
    )
    .unwrap();
    let e = OutDir::check(&out, "demo", &[], true).unwrap_err();
    assert!(refusal(&e).contains("outside its folder"), "{e}");
}
