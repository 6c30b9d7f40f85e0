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

// ---------------------------------------------------------------------------
// The module graph: folders are layers.
//
// Each top-level module of src/ (a folder or a file; src/bin is the program,
// not the library, and is left out) is a node; module `a` depends on `b` when
// any code in `a`'s files names `crate::b::..` (in a `use`, a grouped `use
// crate::{..}`, or a path in code), `crate::X` for a name the crate root
// re-exports from `b`, or climbs out of `a` with `super::super::..`. Comments
// and string literals are not code and are skipped. The same graph is drawn
// inside every folder between its files and sub-folders (the folder's
// mod.rs is the folder itself and may be used by all of them).

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

/// `text` with comments, string literals and character literals blanked to
/// spaces (newlines kept, so line numbers still hold).
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    let mut i = 0;
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    while i < c.len() {
        let prev_ident = i > 0 && ident(c[i - 1]);
        if c[i] == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if c[i] == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if !prev_ident && (c[i] == 'r' || (c[i] == 'b' && c.get(i + 1) == Some(&'r'))) && {
            let mut j = i + if c[i] == 'b' { 2 } else { 1 };
            while c.get(j) == Some(&'#') {
                j += 1;
            }
            c.get(j) == Some(&'"')
        } {
            // A raw string: r"..", r#".."#, br#".."#.
            let mut j = i + if c[i] == 'b' { 2 } else { 1 };
            let mut hashes = 0;
            while c[j] == '#' {
                hashes += 1;
                j += 1;
            }
            j += 1;
            loop {
                if j >= c.len() {
                    break;
                }
                if c[j] == '"' && (0..hashes).all(|k| c.get(j + 1 + k) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            for &ch in &c[i..j.min(c.len())] {
                blank(&mut out, ch);
            }
            i = j;
        } else if c[i] == '"' {
            blank(&mut out, c[i]);
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    blank(&mut out, c[i]);
                    i += 1;
                }
                if i < c.len() {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
            if i < c.len() {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if c[i] == '\'' {
            // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
            let end = if c.get(i + 1) == Some(&'\\') {
                (i + 3..c.len()).find(|&j| c[j] == '\'').map(|j| j + 1)
            } else if c.get(i + 2) == Some(&'\'') {
                Some(i + 3)
            } else {
                None
            };
            match end {
                Some(end) => {
                    for &ch in &c[i..end] {
                        blank(&mut out, ch);
                    }
                    i = end;
                }
                None => {
                    out.push(c[i]);
                    i += 1;
                }
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// One path a file names, resolved to an absolute module path (segments
/// after `crate`), with the line it is on.
#[derive(Debug, Clone)]
struct Named {
    path: Vec<String>,
    line: usize,
}

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

fn skip_ws(s: &[u8], i: &mut usize) {
    while *i < s.len() && s[*i].is_ascii_whitespace() {
        *i += 1;
    }
}

fn read_ident(s: &[u8], i: &mut usize) -> Option<String> {
    let start = *i;
    while *i < s.len() && is_ident(s[*i]) {
        *i += 1;
    }
    (*i > start).then(|| String::from_utf8_lossy(&s[start..*i]).into_owned())
}

/// Reads a path or a use tree at `i` (`a::b::C`, `a::{b, c::{D, E}}`,
/// `a::*`), pushing every full path (relative, as written) onto `out`.
fn read_tree(s: &[u8], i: &mut usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) {
    skip_ws(s, i);
    if *i < s.len() && s[*i] == b'{' {
        *i += 1;
        loop {
            skip_ws(s, i);
            if *i >= s.len() || s[*i] == b'}' {
                *i += 1;
                return;
            }
            read_tree(s, i, prefix.clone(), out);
            skip_ws(s, i);
            if *i < s.len() && s[*i] == b',' {
                *i += 1;
            }
        }
    }
    if *i < s.len() && s[*i] == b'*' {
        *i += 1;
        out.push(prefix);
        return;
    }
    let Some(id) = read_ident(s, i) else {
        out.push(prefix);
        return;
    };
    let mut path = prefix;
    path.push(id);
    let mut j = *i;
    skip_ws(s, &mut j);
    if s[j..].starts_with(b"::") {
        j += 2;
        let mut k = j;
        skip_ws(s, &mut k);
        if k < s.len() && (is_ident(s[k]) || s[k] == b'{' || s[k] == b'*') {
            *i = j;
            read_tree(s, i, path, out);
            return;
        }
    }
    // `as alias` and generic arguments end the path.
    out.push(path);
}

/// Turns a path as written in module `here` into an absolute one: `crate`,
/// `self` and `super` are resolved; anything else is left relative
/// (returned as `None`).
fn absolute(here: &[String], written: &[String]) -> Option<Vec<String>> {
    let mut segs = written.iter().peekable();
    let mut abs: Vec<String> = match segs.peek().map(|s| s.as_str()) {
        Some("crate") => {
            segs.next();
            Vec::new()
        }
        Some("self") => {
            segs.next();
            here.to_vec()
        }
        Some("super") => here.to_vec(),
        _ => return None,
    };
    while segs.peek().map(|s| s.as_str()) == Some("super") {
        segs.next();
        abs.pop()?;
    }
    abs.extend(segs.filter(|s| *s != "self").cloned());
    Some(abs)
}

/// Every absolute path the file names; `module` is the file's own module
/// path (inline `mod x { .. }` blocks are followed).
fn named_paths(text: &str, module: &[String]) -> Vec<Named> {
    let code = code_only(text);
    let s = code.as_bytes();
    let mut found = Vec::new();
    // The module stack: (name, brace depth at which its block closes).
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut line = 1;
    let mut i = 0;
    while i < s.len() {
        let b = s[i];
        if b == b'\n' {
            line += 1;
            i += 1;
            continue;
        }
        if b == b'{' {
            depth += 1;
            i += 1;
            continue;
        }
        if b == b'}' {
            if inline.last().is_some_and(|(_, d)| *d == depth) {
                inline.pop();
            }
            depth = depth.saturating_sub(1);
            i += 1;
            continue;
        }
        if !is_ident(b) || (i > 0 && (is_ident(s[i - 1]) || s[i - 1] == b'$')) {
            i += 1;
            continue;
        }
        let start = i;
        let word = read_ident(s, &mut i).unwrap();
        if word == "mod" {
            let mut j = i;
            skip_ws(s, &mut j);
            if let Some(name) = read_ident(s, &mut j) {
                skip_ws(s, &mut j);
                if j < s.len() && s[j] == b'{' {
                    inline.push((name, depth + 1));
                }
            }
            continue;
        }
        if !matches!(word.as_str(), "crate" | "self" | "super") {
            continue;
        }
        let mut j = i;
        skip_ws(s, &mut j);
        if !s[j..].starts_with(b"::") {
            continue;
        }
        let here: Vec<String> = module
            .iter()
            .cloned()
            .chain(inline.iter().map(|(n, _)| n.clone()))
            .collect();
        let mut k = start;
        let mut trees = Vec::new();
        read_tree(s, &mut k, Vec::new(), &mut trees);
        let lines_in = s[start..k.min(s.len())].iter().filter(|&&c| c == b'\n');
        for t in &trees {
            if let Some(path) = absolute(&here, t) {
                found.push(Named { path, line });
            }
        }
        line += lines_in.count();
        i = k;
    }
    found
}

/// A Rust file of the library and the module path it defines.
struct SourceFile {
    rel: String,
    module: Vec<String>,
    text: String,
    /// Every absolute path the file names.
    named: Vec<Named>,
}

impl SourceFile {
    fn new(rel: String, module: Vec<String>, text: String) -> SourceFile {
        let named = named_paths(&text, &module);
        SourceFile {
            rel,
            module,
            text,
            named,
        }
    }
}

/// The library's files, read once for all the tests here.
fn library_files() -> &'static [SourceFile] {
    static FILES: std::sync::OnceLock<Vec<SourceFile>> = std::sync::OnceLock::new();
    FILES.get_or_init(read_library_files)
}

fn read_library_files() -> Vec<SourceFile> {
    fn walk(dir: &std::path::Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(p);
            }
        }
    }
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut paths = Vec::new();
    walk(&src, &mut paths);
    paths
        .into_iter()
        .filter(|p| !p.starts_with(src.join("bin")))
        .map(|p| {
            let rel = p
                .strip_prefix(&src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            let mut module: Vec<String> = rel
                .trim_end_matches(".rs")
                .split('/')
                .map(str::to_string)
                .collect();
            if matches!(module.last().map(|s| s.as_str()), Some("mod" | "lib")) {
                module.pop();
            }
            let text = std::fs::read_to_string(&p).unwrap();
            SourceFile::new(format!("src/{rel}"), module, text)
        })
        .collect()
}

/// The names a folder's own file (mod.rs, or lib.rs for the crate root)
/// re-exports from its children: `pub use child::Name` lets siblings write
/// `super::Name` for what is really `child::Name`.
fn reexports(files: &[SourceFile], folder: &[String]) -> BTreeMap<String, String> {
    let mut map = BTreeMap::new();
    let own = files
        .iter()
        .find(|f| f.module == folder && (f.rel.ends_with("/mod.rs") || f.rel == "src/lib.rs"));
    let Some(own) = own else {
        return map;
    };
    let code = code_only(&own.text);
    let s = code.as_bytes();
    let mut i = 0;
    while let Some(at) = code[i..].find("use ") {
        let start = i + at;
        i = start + 4;
        if start > 0 && is_ident(s[start - 1]) {
            continue;
        }
        let mut trees = Vec::new();
        let mut k = i;
        read_tree(s, &mut k, Vec::new(), &mut trees);
        for t in trees {
            // Relative to the folder (2018 paths) or through self/crate.
            let abs = absolute(folder, &t)
                .unwrap_or_else(|| folder.iter().cloned().chain(t.iter().cloned()).collect());
            if abs.len() > folder.len() + 1 && abs.starts_with(folder) {
                map.insert(abs.last().unwrap().clone(), abs[folder.len()].clone());
            }
        }
    }
    map
}

/// One edge of a module graph with the first place that makes it.
type Graph = BTreeMap<String, BTreeMap<String, String>>;

/// The graph between the children of `folder` (an empty folder is src/):
/// child `a` depends on child `b` when a file under `a` names a path under
/// `folder::b`, directly or through a name `folder`'s own file re-exports.
fn folder_graph(files: &[SourceFile], folder: &[String]) -> Graph {
    let children: BTreeSet<String> = files
        .iter()
        .filter(|f| f.module.len() > folder.len() && f.module.starts_with(folder))
        .map(|f| f.module[folder.len()].clone())
        .collect();
    let reexported = reexports(files, folder);
    let mut graph: Graph = children
        .iter()
        .map(|c| (c.clone(), BTreeMap::new()))
        .collect();
    for f in files {
        if f.module.len() <= folder.len() || !f.module.starts_with(folder) {
            continue;
        }
        let from = &f.module[folder.len()];
        for n in &f.named {
            if n.path.len() <= folder.len() || !n.path.starts_with(folder) {
                continue;
            }
            let seg = &n.path[folder.len()];
            let to = if children.contains(seg) {
                seg
            } else if let Some(child) = reexported.get(seg) {
                child
            } else {
                continue;
            };
            if to != from {
                let witness = format!("{}:{} names {}", f.rel, n.line, n.path.join("::"));
                graph
                    .get_mut(from)
                    .unwrap()
                    .entry(to.clone())
                    .or_insert(witness);
            }
        }
    }
    graph
}

/// The loops of `graph`: its strongly connected components of more than
/// one node, each with one shortest cycle through its first node, written
/// `a -> b -> a` with the place that makes each step.
fn loops(graph: &Graph) -> Vec<String> {
    // Tarjan's algorithm.
    struct State<'g> {
        g: &'g Graph,
        index: BTreeMap<&'g str, usize>,
        low: BTreeMap<&'g str, usize>,
        stack: Vec<&'g str>,
        on: BTreeSet<&'g str>,
        sccs: Vec<Vec<&'g str>>,
    }
    fn visit<'g>(st: &mut State<'g>, v: &'g str) {
        let n = st.index.len();
        st.index.insert(v, n);
        st.low.insert(v, n);
        st.stack.push(v);
        st.on.insert(v);
        for w in st.g[v].keys() {
            let w = w.as_str();
            if !st.g.contains_key(w) {
                continue;
            }
            if !st.index.contains_key(w) {
                visit(st, w);
                let lw = st.low[w];
                let lv = st.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if st.on.contains(w) {
                let iw = st.index[w];
                let lv = st.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if st.low[v] == st.index[v] {
            let mut scc = Vec::new();
            loop {
                let w = st.stack.pop().unwrap();
                st.on.remove(w);
                scc.push(w);
                if w == v {
                    break;
                }
            }
            st.sccs.push(scc);
        }
    }
    let mut st = State {
        g: graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        sccs: Vec::new(),
    };
    for v in graph.keys() {
        if !st.index.contains_key(v.as_str()) {
            visit(&mut st, v);
        }
    }
    let mut found = Vec::new();
    for mut scc in st.sccs.into_iter().filter(|s| s.len() > 1) {
        scc.sort();
        let members: BTreeSet<&str> = scc.iter().copied().collect();
        // Breadth-first from the first member back to itself.
        let start = scc[0];
        let mut came_from: BTreeMap<&str, &str> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([start]);
        let mut back = None;
        'search: while let Some(v) = queue.pop_front() {
            for w in graph[v].keys().map(|w| w.as_str()) {
                if w == start {
                    back = Some(v);
                    break 'search;
                }
                if members.contains(w) && !came_from.contains_key(w) {
                    came_from.insert(w, v);
                    queue.push_back(w);
                }
            }
        }
        let mut cycle = vec![back.unwrap()];
        while *cycle.last().unwrap() != start {
            cycle.push(came_from[cycle.last().unwrap()]);
        }
        cycle.reverse();
        cycle.push(start);
        let steps: Vec<String> = cycle
            .windows(2)
            .map(|w| format!("    {} -> {}: {}", w[0], w[1], graph[w[0]][w[1]]))
            .collect();
        found.push(format!(
            "{} (a loop among {{{}}})\n{}",
            cycle.join(" -> "),
            scc.join(", "),
            steps.join("\n")
        ));
    }
    found
}

/// The layers of src/, ground first: a module imports only modules of its
/// own layer or of layers below it (and, with the loop test, never one that
/// imports it back). docs/architecture.md draws the same list.
const LAYERS: [(&str, &[&str]); 13] = [
    ("io", &["limits", "source", "input", "io", "numbers"]),
    (
        "geometry",
        &["geom", "placement", "shape_fit", "mesh", "contour"],
    ),
    ("machine", &["machine"]),
    ("kinematics", &["kinematics"]),
    (
        "model and files",
        &["model", "errorfile", "conformance", "formats"],
    ),
    ("NC programs", &["post", "nc"]),
    (
        "identification and compensation",
        &["identify", "compensate"],
    ),
    ("tests", &["procedure"]),
    ("simulation", &["simulate"]),
    ("analysis", &["analyze"]),
    ("reports and the store", &["report", "store"]),
    ("discovery and history", &["discover", "history"]),
    ("the demo", &["demo"]),
];

/// Loops inside a folder that are still there, each with the members of
/// its loop and why it is not broken yet. The test fails when one of them
/// changes or goes (then this list shrinks), and on any other loop.
const KNOWN_FOLDER_LOOPS: [(&str, &[&str], &str); 1] = [(
    "procedure",
    &["bounds", "machining", "outputs", "probing", "template"],
    "Template (template.rs) holds every test's template while both plans hold a Template; \
         TemplateSource sits with it and bounds.rs checks against it; outputs.rs writes the \
         plans and holds the number helpers they use",
)];

fn top_level_graph() -> Graph {
    folder_graph(library_files(), &[])
}

#[test]
fn no_two_top_level_modules_import_each_other() {
    let found = loops(&top_level_graph());
    assert!(
        found.is_empty(),
        "the top-level modules of src/ import each other in a loop; move the definition a lower \
         module needs down to it (docs/architecture.md):\n{}",
        found.join("\n")
    );
}

#[test]
fn every_import_runs_down_the_layers() {
    let graph = top_level_graph();
    let layer_of = |m: &str| LAYERS.iter().position(|(_, ms)| ms.contains(&m));
    let unplaced: Vec<&String> = graph.keys().filter(|m| layer_of(m).is_none()).collect();
    assert!(
        unplaced.is_empty(),
        "top-level modules in no layer of LAYERS (tests/architecture.rs) and docs/architecture.md: {unplaced:?}"
    );
    let gone: Vec<&str> = LAYERS
        .iter()
        .flat_map(|(_, ms)| ms.iter().copied())
        .filter(|m| !graph.contains_key(*m))
        .collect();
    assert!(
        gone.is_empty(),
        "LAYERS names modules src/ does not have: {gone:?}"
    );
    let mut upward = Vec::new();
    for (from, tos) in &graph {
        for (to, witness) in tos {
            let (lf, lt) = (layer_of(from).unwrap(), layer_of(to).unwrap());
            if lt > lf {
                upward.push(format!(
                    "{from} ({}) imports {to} ({}): {witness}",
                    LAYERS[lf].0, LAYERS[lt].0
                ));
            }
        }
    }
    assert!(
        upward.is_empty(),
        "imports that run up the layers:\n{}",
        upward.join("\n")
    );
}

#[test]
fn no_two_files_of_a_folder_import_each_other() {
    let files = library_files();
    let folders: BTreeSet<Vec<String>> = files
        .iter()
        .filter(|f| f.rel.ends_with("/mod.rs"))
        .map(|f| f.module.clone())
        .collect();
    let mut problems = Vec::new();
    let mut known_seen = BTreeSet::new();
    for folder in &folders {
        let name = folder.join("/");
        for l in loops(&folder_graph(files, folder)) {
            let members = l[l.find('{').unwrap() + 1..l.find('}').unwrap()].to_string();
            let known = KNOWN_FOLDER_LOOPS
                .iter()
                .find(|(f, ms, _)| *f == name && ms.join(", ") == members);
            match known {
                Some(_) => {
                    known_seen.insert(name.clone());
                }
                None => problems.push(format!("in src/{name}/: {l}")),
            }
        }
    }
    for (f, ms, _) in KNOWN_FOLDER_LOOPS {
        if !known_seen.contains(f) {
            problems.push(format!(
                "src/{f}/ no longer has the loop among {{{}}} that KNOWN_FOLDER_LOOPS lists: take it off the list",
                ms.join(", ")
            ));
        }
    }
    assert!(
        problems.is_empty(),
        "files or sub-folders of one folder import each other; move what both need to a file \
         they both stand on (or the folder's mod.rs):\n{}",
        problems.join("\n")
    );
}

fn file(rel: &str, module: &[&str], text: &str) -> SourceFile {
    SourceFile::new(
        rel.to_string(),
        module.iter().map(|s| s.to_string()).collect(),
        text.to_string(),
    )
}

#[test]
fn the_graph_reads_grouped_uses_paths_in_code_and_super_escapes_but_not_comments_or_strings() {
    let text = r##"//! [`crate::history`] in a comment is not code
use crate::{geom::Axis3, machine::{Dialect, Machine}};
use super::super::limits::MAX;
/* crate::demo::run() in a block comment */
fn f<'a>(x: &'a str) {
    let s = "crate::report::page";
    let q = '"';
    let r = r#"crate::store::open"#;
    crate::io::write_atomic(x, s);
    let _ = crate::Machine::builtin("bc-trunnion");
}
mod tests {
    use super::super::super::post::Op;
}
"##;
    let here = ["formats", "probe_log"].map(String::from);
    let got: Vec<String> = named_paths(text, &here)
        .iter()
        .map(|n| format!("{}:{}", n.line, n.path.join("::")))
        .collect();
    assert_eq!(
        got,
        [
            "2:geom::Axis3",
            "2:machine::Dialect",
            "2:machine::Machine",
            "3:limits::MAX",
            "9:io::write_atomic",
            "10:Machine::builtin",
            "13:post::Op",
        ]
    );
}

#[test]
fn a_loop_is_named_with_the_places_that_make_it_and_reexports_are_followed() {
    // The crate root re-exports `Thing` from b; a names it as crate::Thing.
    let files = [
        file(
            "src/lib.rs",
            &[],
            "pub mod a;\npub mod b;\npub mod c;\npub use b::Thing;\n",
        ),
        file("src/a.rs", &["a"], "use crate::Thing;\n"),
        file("src/b/mod.rs", &["b"], "mod x;\npub use x::Thing;\n"),
        file(
            "src/b/x.rs",
            &["b", "x"],
            "pub struct Thing;\nfn f() { super::super::c::g() }\n",
        ),
        file(
            "src/c.rs",
            &["c"],
            "pub fn g() {}\nfn h() { crate::a::k() }\n",
        ),
    ];
    let graph = folder_graph(&files, &[]);
    assert_eq!(
        loops(&graph),
        ["a -> b -> c -> a (a loop among {a, b, c})\n    \
          a -> b: src/a.rs:1 names Thing\n    \
          b -> c: src/b/x.rs:2 names c::g\n    \
          c -> a: src/c.rs:2 names a::k"]
    );
    // Inside b, the re-exported name leads to the file that defines it.
    let files = [
        file(
            "src/b/mod.rs",
            &["b"],
            "mod x;\nmod y;\npub use x::Thing;\n",
        ),
        file(
            "src/b/x.rs",
            &["b", "x"],
            "pub struct Thing;\nuse super::y::Other;\n",
        ),
        file(
            "src/b/y.rs",
            &["b", "y"],
            "pub struct Other(super::Thing);\n",
        ),
    ];
    assert_eq!(loops(&folder_graph(&files, &["b".to_string()])).len(), 1);
}
