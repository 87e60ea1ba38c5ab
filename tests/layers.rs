//! The module import graph of every crate has no cycles: data flows one way. The
//! client's dependency tree holds neither the server nor the store. No source file or
//! function is too long (at the end of this file). Every solver file that runs a faer
//! decomposition clears the vector registers after it (`upper_state`).
//!
//! Each crate's modules (`src/a.rs`, `src/a/b.rs`, `src/a/b/mod.rs`) are grouped two
//! levels deep (`a::b`); a module imports another when its text names it by a `crate::`
//! path (in `use` lines, in code and in doc links alike) or a `super::` path, outside its
//! `#[cfg(test)] mod tests` block. The strongly connected components of that graph
//! (Tarjan) are the cycles; none may appear but those listed in [`KNOWN`], which are
//! being taken apart.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Cycles that exist and are being taken apart (crate, modules). A cycle found must lie
/// inside one of these; remove an entry once its cycle is gone.
const KNOWN: &[(&str, &[&str])] = &[];

/// Grouping depth of module paths.
const DEPTH: usize = 2;

fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("a source directory reads") {
        let p = e.expect("an entry reads").path();
        if p.is_dir() {
            rs_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a source file (`a::b`; `` for lib.rs or main.rs).
fn module_of(root: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(root).expect("under the root");
    let mut parts: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|l| l == "mod") {
        parts.pop();
    }
    if parts.len() == 1 && (parts[0] == "lib" || parts[0] == "main") {
        parts.clear();
    }
    parts.join("::")
}

fn group(m: &str) -> String {
    m.split("::").take(DEPTH).collect::<Vec<_>>().join("::")
}

/// The identifier paths following each occurrence of `prefix` in `text`.
fn paths_after<'a>(text: &'a str, prefix: &'a str) -> impl Iterator<Item = Vec<&'a str>> + 'a {
    text.match_indices(prefix).filter_map(move |(i, _)| {
        let before = text[..i].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            return None;
        }
        let rest = &text[i + prefix.len()..];
        let mut parts = vec![];
        let mut s = rest;
        loop {
            let n = s
                .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
                .unwrap_or(s.len());
            if n == 0 || !s.starts_with(|c: char| c.is_ascii_lowercase() || c == '_') {
                break;
            }
            parts.push(&s[..n]);
            s = &s[n..];
            match s.strip_prefix("::") {
                Some(r) => s = r,
                None => break,
            }
        }
        (!parts.is_empty()).then_some(parts)
    })
}

/// The module graph of the crate whose sources are under `root` (grouped modules).
fn graph(root: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = vec![];
    rs_files(root, &mut files);
    let mods: BTreeMap<String, String> = files
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(f).expect("a source file reads");
            let code = match text.find("#[cfg(test)]\nmod tests") {
                Some(i) => text[..i].to_string(),
                None => text,
            };
            (module_of(root, f), code)
        })
        .collect();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, text) in &mods {
        let from = group(m);
        if from.is_empty() {
            continue;
        }
        let mut add = |target: String| {
            let to = group(&target);
            if !to.is_empty() && to != from {
                edges.entry(from.clone()).or_default().insert(to);
            }
        };
        for parts in paths_after(text, "crate::") {
            // The longest prefix of the path that is a module.
            let best = (1..=parts.len())
                .map(|n| parts[..n].join("::"))
                .rfind(|c| mods.contains_key(c));
            if let Some(b) = best {
                add(b);
            }
        }
        for parts in paths_after(text, "super::") {
            let parent = m.rsplit_once("::").map_or("", |(p, _)| p);
            let cand = if parent.is_empty() {
                parts[0].to_string()
            } else {
                format!("{parent}::{}", parts[0])
            };
            if mods.contains_key(&cand) {
                add(cand);
            }
        }
    }
    edges
}

/// Strongly connected components with more than one module (Tarjan).
fn cycles(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<BTreeSet<String>> {
    struct T<'a> {
        edges: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        next: usize,
        out: Vec<BTreeSet<String>>,
    }
    impl<'a> T<'a> {
        fn visit(&mut self, v: &'a str) {
            self.index.insert(v, self.next);
            self.low.insert(v, self.next);
            self.next += 1;
            self.stack.push(v);
            self.on.insert(v);
            let edges = self.edges;
            for w in edges.get(v).into_iter().flatten() {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let l = self.low[v].min(self.low[w]);
                    self.low.insert(v, l);
                } else if self.on.contains(w) {
                    let l = self.low[v].min(self.index[w]);
                    self.low.insert(v, l);
                }
            }
            if self.low[v] == self.index[v] {
                let mut comp = BTreeSet::new();
                loop {
                    let w = self.stack.pop().expect("on the stack");
                    self.on.remove(w);
                    comp.insert(w.to_string());
                    if w == v {
                        break;
                    }
                }
                if comp.len() > 1 {
                    self.out.push(comp);
                }
            }
        }
    }
    let mut t = T {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: vec![],
        on: BTreeSet::new(),
        next: 0,
        out: vec![],
    };
    for v in edges.keys() {
        if !t.index.contains_key(v.as_str()) {
            t.visit(v);
        }
    }
    t.out
}

#[test]
fn no_module_import_cycles() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut crates: Vec<(String, PathBuf)> = vec![("mtcal".into(), root.join("src"))];
    for e in std::fs::read_dir(root.join("crates")).expect("crates/ reads") {
        let p = e.expect("an entry reads").path();
        if p.join("src").is_dir() {
            let name = p.file_name().expect("named").to_string_lossy().into_owned();
            crates.push((name, p.join("src")));
        }
    }
    let mut found = vec![];
    for (name, src) in &crates {
        let edges = graph(src);
        for c in cycles(&edges) {
            let known = KNOWN
                .iter()
                .any(|(k, ms)| k == name && c.iter().all(|m| ms.contains(&m.as_str())));
            if !known {
                let lines: Vec<String> = c
                    .iter()
                    .map(|m| {
                        let to: Vec<&str> = edges[m]
                            .iter()
                            .filter(|t| c.contains(*t))
                            .map(String::as_str)
                            .collect();
                        format!("    {m} -> {}", to.join(", "))
                    })
                    .collect();
                found.push(format!("crates/{name}: {}", lines.join("\n")));
            }
        }
    }
    assert!(
        found.is_empty(),
        "module import cycles:\n{}",
        found.join("\n")
    );
}

/// The checker sees a cycle through `use`, code and `super::` paths, and none in a
/// one-way graph.
#[test]
fn the_checker_finds_a_planted_cycle() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let src = dir.path();
    std::fs::create_dir_all(src.join("a")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod a; pub mod b; pub mod c;").unwrap();
    std::fs::write(src.join("a/mod.rs"), "pub mod x;").unwrap();
    std::fs::write(src.join("a/x.rs"), "use crate::b::thing;").unwrap();
    std::fs::write(src.join("b.rs"), "pub fn thing() { crate::c::f() }").unwrap();
    std::fs::write(
        src.join("c.rs"),
        "pub fn f() {}\n#[cfg(test)]\nmod tests { use crate::a::x; }",
    )
    .unwrap();
    assert!(cycles(&graph(src)).is_empty());
    std::fs::write(src.join("c.rs"), "pub fn f() { crate::a::x::g() }").unwrap();
    let c = cycles(&graph(src));
    assert_eq!(c.len(), 1, "{c:?}");
    assert_eq!(
        c[0],
        ["a::x", "b", "c"].iter().map(|s| s.to_string()).collect()
    );
    // A super:: path closes a cycle too.
    std::fs::write(src.join("a/mod.rs"), "pub mod x; pub mod y;").unwrap();
    std::fs::write(src.join("a/x.rs"), "use super::y::h;").unwrap();
    std::fs::write(src.join("a/y.rs"), "use crate::a::x::k;").unwrap();
    std::fs::write(src.join("c.rs"), "pub fn f() {}").unwrap();
    let c = cycles(&graph(src));
    assert_eq!(c.len(), 1, "{c:?}");
    assert!(c[0].contains("a::x") && c[0].contains("a::y"));
}

/// The packages `cargo tree` shows package `pkg` linking through its normal dependencies
/// (itself included), by name.
fn linked(pkg: &str) -> BTreeSet<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["tree", "--offline", "-p", pkg, "-e", "normal"])
        .args(["--prefix", "none", "--format", "{p}"])
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree -p {pkg}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(String::from)
        .collect()
}

/// The typed client shares the API's types through `mtcal-api` and links neither the
/// server nor the store: no axum, no sqlx. The same reading of the tree finds them in
/// the server, so the check can fail.
#[test]
fn the_client_links_neither_http_server_nor_database() {
    let banned = [
        "axum",
        "axum-core",
        "sqlx",
        "sqlx-core",
        "mtcal-server",
        "mtcal-store",
        "mtcal-domain",
        "mtcal-views",
    ];
    let client = linked("mtcal-client");
    assert!(client.contains("mtcal-api"), "{client:?}");
    let found: Vec<&str> = banned
        .iter()
        .copied()
        .filter(|b| client.contains(*b))
        .collect();
    assert!(found.is_empty(), "mtcal-client links {found:?}");
    let server = linked("mtcal-server");
    for b in ["axum", "sqlx", "mtcal-store", "mtcal-api"] {
        assert!(
            server.contains(b),
            "the server's tree lacks {b}: {server:?}"
        );
    }
}

// Sizes a reader can hold: no source file over MAX_FILE_LINES lines and no function over
// MAX_FN_LINES lines, across `crates/*/src` and `src/`. A function's lines run from its
// `fn` keyword to its closing brace (its documentation and attributes not counted);
// functions nested in others, methods and trait methods with a body count alike. A long
// function is split into named steps; none may be too long but those listed in
// KNOWN_LONG, which are being split.

/// Functions over [`MAX_FN_LINES`] lines that exist and are being split (file, name).
/// A function found too long must be one of these; remove an entry once its function
/// is split.
const KNOWN_LONG: &[(&str, &str)] = &[("crates/solver/src/diagnosis/locate.rs", "locate")];

/// Longest source file, lines.
const MAX_FILE_LINES: usize = 1000;
/// Longest function, lines.
const MAX_FN_LINES: usize = 150;

/// Every function of a file with a body: (first line, name, lines).
struct Functions(Vec<(usize, String, usize)>);

impl Functions {
    fn add(&mut self, sig: &syn::Signature, body: &syn::Block) {
        let (first, last) = (
            sig.fn_token.span.start().line,
            syn::spanned::Spanned::span(body).end().line,
        );
        self.0
            .push((first, sig.ident.to_string(), last + 1 - first));
    }
}

impl<'ast> syn::visit::Visit<'ast> for Functions {
    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        self.add(&f.sig, &f.block);
        syn::visit::visit_item_fn(self, f);
    }
    fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
        self.add(&f.sig, &f.block);
        syn::visit::visit_impl_item_fn(self, f);
    }
    fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
        if let Some(body) = &f.default {
            self.add(&f.sig, body);
        }
        syn::visit::visit_trait_item_fn(self, f);
    }
}

/// What is too long in the source `text` of `name`, one line each: the file, and each
/// function as `name:line: fn f has n lines`.
fn too_long(name: &str, text: &str) -> Vec<String> {
    let mut found = vec![];
    let lines = text.lines().count();
    if lines > MAX_FILE_LINES {
        found.push(format!("{name}: {lines} lines (at most {MAX_FILE_LINES})"));
    }
    let file = syn::parse_file(text).unwrap_or_else(|e| panic!("{name} parses: {e}"));
    let mut fns = Functions(vec![]);
    syn::visit::Visit::visit_file(&mut fns, &file);
    for (line, f, n) in fns.0 {
        if n > MAX_FN_LINES {
            found.push(format!(
                "{name}:{line}: fn {f} has {n} lines (at most {MAX_FN_LINES})"
            ));
        }
    }
    found
}

#[test]
fn no_file_or_function_is_too_long() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![];
    rs_files(&root.join("src"), &mut files);
    for e in std::fs::read_dir(root.join("crates")).expect("crates/ reads") {
        let src = e.expect("an entry reads").path().join("src");
        if src.is_dir() {
            rs_files(&src, &mut files);
        }
    }
    assert!(files.len() > 100, "only {} source files found", files.len());
    files.sort();
    let found: Vec<String> = files
        .iter()
        .flat_map(|f| {
            let text = std::fs::read_to_string(f).expect("a source file reads");
            let name = f.strip_prefix(root).unwrap_or(f).display().to_string();
            too_long(&name, &text)
        })
        .collect();
    let is_known = |line: &str, (file, f): &(&str, &str)| {
        line.starts_with(&format!("{file}:")) && line.contains(&format!(": fn {f} has "))
    };
    let new: Vec<&str> = found
        .iter()
        .map(String::as_str)
        .filter(|l| !KNOWN_LONG.iter().any(|k| is_known(l, k)))
        .collect();
    assert!(new.is_empty(), "too long:\n{}", new.join("\n"));
}

/// A function of `n` lines from `fn` to its closing brace, preceded by documentation.
fn function(name: &str, n: usize) -> String {
    let mut s = format!("/// Documented.\n#[inline]\npub fn {name}() -> u32 {{\n");
    for i in 0..n - 3 {
        s.push_str(&format!("    let _x{i} = {i};\n"));
    }
    s.push_str("    0\n}\n");
    assert_eq!(s.lines().count(), n + 2);
    s
}

/// The checker counts a function's lines as stated (150 pass, 151 do not; methods and
/// nested functions too) and a file's lines (1000 pass, 1001 do not).
#[test]
fn the_checker_counts_as_stated() {
    let ok = function("fits", 150);
    assert!(too_long("ok.rs", &ok).is_empty());
    let long = too_long("long.rs", &function("long", 151));
    assert_eq!(long, ["long.rs:3: fn long has 151 lines (at most 150)"]);
    let method = format!("struct S;\nimpl S {{\n{}}}\n", function("m", 151));
    assert_eq!(too_long("m.rs", &method).len(), 1);
    let nested = format!("fn outer() {{\n{}}}\n", function("inner", 151));
    let found = too_long("n.rs", &nested);
    assert!(
        found.iter().any(|f| f.contains("fn inner has 151")),
        "{found:?}"
    );
    let file = |n: usize| "// a line\n".repeat(n);
    assert!(too_long("a.rs", &file(1000)).is_empty());
    assert_eq!(
        too_long("b.rs", &file(1001)),
        ["b.rs: 1001 lines (at most 1000)"]
    );
}

/// Calls that run faer's decompositions, and with them its AVX-512 kernels.
const FAER_ROUTINES: &[&str] = &[".qr()", ".svd()", ".thin_svd()", "qr_in_place("];

/// Of the source files `(name, text)`, those that run a faer routine ([`FAER_ROUTINES`])
/// and never call `upper_state::clear` (crates/solver/src/upper_state.rs: after faer's
/// kernels every call of the C library's `exp` or `atan2` costs about 30 times more
/// until it runs). A faer product (`&a * &b`) is not detected.
fn faer_without_clear(files: &[(String, String)]) -> Vec<String> {
    files
        .iter()
        .filter(|(_, text)| {
            FAER_ROUTINES.iter().any(|r| text.contains(r)) && !text.contains("upper_state::clear()")
        })
        .map(|(name, _)| name.clone())
        .collect()
}

/// Every solver file that runs a faer decomposition clears the vector registers' upper
/// halves after it; the check finds a planted file that does not.
#[test]
fn every_faer_routine_clears_the_vector_registers() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/solver/src");
    let mut files = vec![];
    rs_files(&root, &mut files);
    let texts: Vec<(String, String)> = files
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(f).expect("a source file reads");
            (f.display().to_string(), text)
        })
        .collect();
    let running = texts
        .iter()
        .filter(|(_, t)| FAER_ROUTINES.iter().any(|r| t.contains(r)))
        .count();
    assert!(running >= 5, "only {running} files run a faer routine");
    assert_eq!(faer_without_clear(&texts), Vec::<String>::new());
    let planted = [
        ("a.rs", "let qr = m.qr();\n"),
        ("b.rs", "let qr = m.qr();\ncrate::upper_state::clear();\n"),
        ("c.rs", "let x = 1;\n"),
    ]
    .map(|(n, t)| (n.to_string(), t.to_string()));
    assert_eq!(faer_without_clear(&planted), ["a.rs"]);
}
