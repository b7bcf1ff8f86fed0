//! The dependency rules of ARCHITECTURE.md, checked against the code.
//!
//! ARCHITECTURE.md holds, per crate, a table between `<!-- deps:CRATE -->`
//! and `<!-- /deps -->`: each module of the crate and the modules it may
//! import. This test reads every source file of the crate, finds what each
//! module really refers to (`use crate::…`, `crate::…` paths in code,
//! `super::…` in a module's children; comments and `#[cfg(test)]` modules
//! left out), and fails when a module refers to one its row does not
//! allow, when a module is missing from the table or the table names one
//! the code does not have, or when the rules themselves allow a circle. It
//! also fails on a source file over 800 lines that the list between
//! `<!-- long-files -->` and `<!-- /long-files -->` does not name.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The longest file the rules allow without a word in ARCHITECTURE.md.
const MAX_LINES: usize = 800;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn architecture() -> String {
    std::fs::read_to_string(repo().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md is readable")
}

/// The rule table of `krate`: module -> the modules it may import.
fn rules(doc: &str, krate: &str) -> BTreeMap<String, BTreeSet<String>> {
    let open = format!("<!-- deps:{krate} -->");
    let start = doc
        .find(&open)
        .unwrap_or_else(|| panic!("ARCHITECTURE.md has no {open} table"));
    let rest = &doc[start + open.len()..];
    let end = rest
        .find("<!-- /deps -->")
        .expect("the table ends with <!-- /deps -->");
    let mut out = BTreeMap::new();
    for row in rest[..end].lines() {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        // | module | may import | what it is |
        if cells.len() < 4
            || cells[1].is_empty()
            || cells[1] == "module"
            || cells[1].starts_with("--")
        {
            continue;
        }
        let module = cells[1].trim_matches('`').to_string();
        let allowed = cells[2]
            .split(',')
            .map(|s| s.trim().trim_matches('`').to_string())
            .filter(|s| !s.is_empty() && s != "—" && s != "-")
            .collect();
        assert!(
            out.insert(module.clone(), allowed).is_none(),
            "{krate}: {module} has two rows"
        );
    }
    out
}

/// The source files of a crate's library, by module path (`interp::state`;
/// the crate root is ``).
fn modules(src: &Path) -> BTreeMap<String, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).expect("source folder is readable") {
            let p = e.expect("a folder entry").path();
            let rel = p.strip_prefix(src).expect("below src").to_path_buf();
            if rel.starts_with("bin") {
                continue; // binaries are crates of their own, using the library by name
            }
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            if p.extension().is_none_or(|x| x != "rs") {
                continue;
            }
            let mut parts: Vec<String> = rel
                .with_extension("")
                .iter()
                .map(|c| c.to_string_lossy().into_owned())
                .collect();
            if parts.last().is_some_and(|l| l == "mod" || l == "lib") {
                parts.pop();
            }
            out.insert(parts.join("::"), p);
        }
    }
    out
}

/// The code of a file without comments, string contents and its
/// `#[cfg(test)]` module (by this project's layout: at the end).
fn code(text: &str) -> String {
    // (the attribute at the start of a line, the module within the next
    // lines, after any other attributes)
    let cut = text
        .match_indices("\n#[cfg(test)]\n")
        .map(|(i, _)| i)
        .find(|&i| {
            text[i + 14..]
                .lines()
                .take(4)
                .find(|l| !l.starts_with("#["))
                .is_some_and(|l| l.starts_with("mod "))
        });
    let text = match cut {
        Some(i) => &text[..i],
        None => text,
    };
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                i += 1;
            }
            i += 2;
        } else if b[i] == b'"' {
            // a string (raw strings hold no quote-free `crate::` here)
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && b.get(i + 2) == Some(&b'\'') {
            i += 3; // a char literal such as '"'
        } else if b[i] == b'\'' && b.get(i + 1) == Some(&b'\\') {
            i += 2;
            while i < b.len() && b[i] != b'\'' {
                i += 1;
            }
            i += 1;
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

/// Module paths a file's code refers to: each `crate::a::b::…` and
/// `super::…` path, cut to the longest prefix that is a module.
fn refers_to(module: &str, code: &str, known: &BTreeMap<String, PathBuf>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut paths = Vec::new();
    for (prefix, base) in [("crate::", String::new()), ("super::", parent(module))] {
        let mut from = 0;
        while let Some(k) = code[from..].find(prefix) {
            let at = from + k;
            from = at + prefix.len();
            if at > 0
                && (ident(code[..at].chars().last().unwrap_or(' ')) || code[..at].ends_with("::"))
            {
                continue; // part of a longer path (`cnc_core::…`, `self::super::…`)
            }
            // the path, with `{a, b::c}` groups read as several paths
            let tail: String = code[from..]
                .chars()
                .take_while(|&c| {
                    ident(c)
                        || c == ':'
                        || c == '{'
                        || c == '}'
                        || c == ','
                        || c == ' '
                        || c == '\n'
                })
                .collect();
            for p in expand(&tail) {
                let full = if base.is_empty() {
                    p
                } else {
                    format!("{base}::{p}")
                };
                paths.push(full);
            }
        }
    }
    for p in paths {
        let segs: Vec<&str> = p.split("::").filter(|s| !s.is_empty()).collect();
        let mut hit = String::new();
        for n in (1..=segs.len()).rev() {
            let cand = segs[..n].join("::");
            if known.contains_key(&cand) {
                hit = cand;
                break;
            }
        }
        if hit != module {
            out.insert(hit);
        }
    }
    out
}

fn parent(module: &str) -> String {
    match module.rfind("::") {
        Some(i) => module[..i].to_string(),
        None => String::new(),
    }
}

/// `a::{b, c::d}` -> `a::b`, `a::c::d` (one level of braces is enough
/// here); a path ends at the first character that cannot continue it.
fn expand(tail: &str) -> Vec<String> {
    let t: String = tail.chars().filter(|c| !c.is_whitespace()).collect();
    let head_end = t.find(['{', '}', ',']).unwrap_or(t.len());
    let head = t[..head_end].trim_end_matches("::");
    if t[head_end..].starts_with('{') {
        let inner_end = t[head_end..].find('}').map_or(t.len(), |e| head_end + e);
        let inner = &t[head_end + 1..inner_end];
        return inner
            .split(',')
            .filter(|s| !s.is_empty())
            .map(|s| format!("{head}::{s}"))
            .collect();
    }
    vec![head.to_string()]
}

/// The modules the rules let each module reach (to find circles).
fn reaches(rules: &BTreeMap<String, BTreeSet<String>>, from: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo: Vec<&str> = rules
        .get(from)
        .map_or(Vec::new(), |s| s.iter().map(String::as_str).collect());
    while let Some(m) = todo.pop() {
        if seen.insert(m.to_string()) {
            if let Some(next) = rules.get(m) {
                todo.extend(next.iter().map(String::as_str));
            }
        }
    }
    seen
}

fn check_crate(krate: &str, dir: &str) -> Vec<String> {
    let doc = architecture();
    let rules = rules(&doc, krate);
    let src = repo().join(dir).join("src");
    let known = modules(&src);
    let name = |m: &str| {
        if m.is_empty() {
            "(crate root)".to_string()
        } else {
            m.to_string()
        }
    };
    let mut problems = Vec::new();
    for m in known.keys().filter(|m| !m.is_empty()) {
        if !rules.contains_key(m) {
            problems.push(format!("{krate}: module {m} has no row in ARCHITECTURE.md"));
        }
    }
    for m in rules.keys() {
        if !known.contains_key(m) {
            problems.push(format!(
                "{krate}: ARCHITECTURE.md names {m}, which the code does not have"
            ));
        }
        if reaches(&rules, m).contains(m) {
            problems.push(format!(
                "{krate}: the rules let {m} import itself through others (a circle)"
            ));
        }
    }
    for (m, path) in &known {
        if m.is_empty() {
            continue; // the root declares the modules and re-exports
        }
        let text = std::fs::read_to_string(path).expect("source is readable");
        let allowed = rules.get(m).cloned().unwrap_or_default();
        for target in refers_to(m, &code(&text), &known) {
            if !allowed.contains(&target) {
                problems.push(format!(
                    "{krate}: {} imports {}, which its row in ARCHITECTURE.md does not allow",
                    name(m),
                    name(&target)
                ));
            }
        }
    }
    problems
}

#[test]
fn cnc_core_modules_import_only_what_architecture_md_allows() {
    let problems = check_crate("cnc_core", "cnc_core");
    assert!(problems.is_empty(), "\n{}", problems.join("\n"));
}

#[test]
fn cnc_node_modules_import_only_what_architecture_md_allows() {
    let problems = check_crate("cnc_node", "cnc_node");
    assert!(problems.is_empty(), "\n{}", problems.join("\n"));
}

#[test]
fn no_source_file_is_longer_than_800_lines_unless_architecture_md_says_why() {
    let doc = architecture();
    let open = "<!-- long-files -->";
    let listed: BTreeSet<String> = match doc.find(open) {
        Some(s) => {
            let rest = &doc[s + open.len()..];
            let e = rest.find("<!-- /long-files -->").unwrap_or(rest.len());
            rest[..e]
                .lines()
                .filter_map(|l| l.trim().strip_prefix("- `"))
                .filter_map(|l| l.split('`').next())
                .map(str::to_string)
                .collect()
        }
        None => BTreeSet::new(),
    };
    let mut long = Vec::new();
    for dir in ["cnc_core/src", "cnc_node/src", "sim_axes/src", "msgs/src"] {
        let mut stack = vec![repo().join(dir)];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).expect("source folder is readable") {
                let p = e.expect("a folder entry").path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    let n = std::fs::read_to_string(&p)
                        .expect("readable")
                        .lines()
                        .count();
                    let rel = p
                        .strip_prefix(repo())
                        .expect("in the repository")
                        .to_string_lossy()
                        .replace('\\', "/");
                    let rel = rel.trim_start_matches("./").to_string();
                    if n > MAX_LINES && !listed.contains(&rel) {
                        long.push(format!("{rel}: {n} lines"));
                    }
                }
            }
        }
    }
    assert!(
        long.is_empty(),
        "files over {MAX_LINES} lines not explained in ARCHITECTURE.md:\n{}",
        long.join("\n")
    );
}

/// The checker itself: a module that imports one its row does not allow
/// is caught, through `use crate::…`, a path in code and `super::…`; a
/// comment or a string naming a module is not an import.
#[test]
fn the_checker_finds_imports_and_ignores_comments_and_strings() {
    let mut known = BTreeMap::new();
    for m in ["", "a", "b", "c", "d", "d::x", "d::y"] {
        known.insert(m.to_string(), PathBuf::new());
    }
    let src = "use crate::b::{Thing, Other};\n// crate::c::Nope\nfn f() { let s = \"crate::c::x\"; crate::d::x::g(); }\n";
    let got = refers_to("a", &code(src), &known);
    let want: BTreeSet<String> = ["b", "d::x"].iter().map(|s| s.to_string()).collect();
    assert_eq!(got, want);
    let got = refers_to(
        "d::y",
        &code("use super::x::Z;\nuse super::Root;\n"),
        &known,
    );
    let want: BTreeSet<String> = ["d", "d::x"].iter().map(|s| s.to_string()).collect();
    assert_eq!(got, want);
    let rules: BTreeMap<String, BTreeSet<String>> = [
        ("a".to_string(), ["b".to_string()].into()),
        ("b".to_string(), ["a".to_string()].into()),
    ]
    .into();
    assert!(
        reaches(&rules, "a").contains("a"),
        "a circle in the rules is found"
    );
}
