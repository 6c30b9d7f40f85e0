//! `docs/architecture.md` names the real files: every repository path it
//! gives in backticks exists, so a moved or renamed file makes this fail
//! instead of leaving the page pointing at nothing.

use std::path::Path;

/// The backticked spans of `text` that are repository paths (they start
/// with one of the top-level folders); spans with a placeholder such as
/// `<name>` are patterns, not paths.
fn repo_paths(text: &str) -> Vec<&str> {
    const ROOTS: [&str; 8] = [
        "src/",
        "tests/",
        "docs/",
        "templates/",
        "postprocessors/",
        "examples/",
        "benches/",
        "Cargo.toml",
    ];
    text.split('`')
        .skip(1)
        .step_by(2)
        .filter(|s| ROOTS.iter().any(|r| s.starts_with(r)))
        .filter(|s| !s.contains('<') && !s.contains('*'))
        .collect()
}

#[test]
fn every_path_the_architecture_page_names_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("docs/architecture.md")).unwrap();
    let paths = repo_paths(&text);
    // The page names dozens of files; a handful would mean the extraction broke.
    assert!(
        paths.len() > 40,
        "only {} paths found: {paths:?}",
        paths.len()
    );
    assert!(paths.iter().filter(|p| p.starts_with("src/")).count() > 30);
    let missing: Vec<&&str> = paths.iter().filter(|p| !root.join(p).exists()).collect();
    assert!(
        missing.is_empty(),
        "docs/architecture.md names paths that do not exist: {missing:?}"
    );
}

#[test]
fn the_extraction_skips_patterns_and_keeps_paths() {
    let text = "see `src/lib.rs`, `postprocessors/<name>.yaml`, `Effect` and `tests/tests.rs`";
    assert_eq!(repo_paths(text), ["src/lib.rs", "tests/tests.rs"]);
}

#[test]
fn the_architecture_page_is_linked_from_the_readme_and_the_docs_index() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    assert!(readme.contains("docs/architecture.md"));
    let index = std::fs::read_to_string(root.join("docs/README.md")).unwrap();
    assert!(index.contains("(architecture.md)"));
}
