//! ARCHITECTURE.md's rules, checked on the source: no module (and no file, through `crate::`,
//! `super::` or `self::` paths) imports one that imports it back, render knows only camera,
//! scene and raster, only `format` knows RON, the library never names the command line's
//! crates, and every `unsafe` block says why it holds.

use std::collections::{BTreeMap, BTreeSet};

use crate::common::root;

/// Each library module's `crate::` imports, outside comments and unit tests.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let src = root().join("src");
    // Files of src/ and of its module folders (but the command line's): a folder's files
    // belong to the folder's module.
    let mut files = Vec::new();
    for e in std::fs::read_dir(&src).unwrap().flatten() {
        let path = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if name != "cli" {
                for f in std::fs::read_dir(&path).unwrap().flatten() {
                    files.push((name.clone(), f.path()));
                }
            }
        } else if let Some(stem) = name.strip_suffix(".rs") {
            files.push((stem.to_string(), path));
        }
    }
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, f) in &files {
        if f.extension().is_none_or(|x| x != "rs") {
            continue;
        }
        let module = module.clone();
        if module == "lib" || module == "main" {
            continue;
        }
        let text = std::fs::read_to_string(f).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap();
        let deps = out.entry(module.clone()).or_default();
        for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for (i, _) in line.match_indices("crate::") {
                let name: String = line[i + 7..]
                    .chars()
                    .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                    .collect();
                if !name.is_empty() && name != module {
                    deps.insert(name);
                }
            }
            for krate in ["clap", "indicatif", "plotters"] {
                assert!(
                    !line.contains(&format!("{krate}::")),
                    "{module} names {krate}: {line}"
                );
            }
            if module != "format" {
                assert!(!line.contains("ron::"), "{module} knows RON: {line}");
            }
        }
    }
    out
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let deps = imports();
    for module in ["document", "export", "render", "format", "output"] {
        assert!(deps.contains_key(module), "{module} missing from {deps:?}");
    }
    // Depth-first search for a path back to the start.
    for start in deps.keys() {
        let mut stack = vec![(start.clone(), vec![start.clone()])];
        let mut seen = BTreeSet::new();
        while let Some((m, path)) = stack.pop() {
            for d in deps.get(&m).into_iter().flatten() {
                assert!(d != start, "cycle: {} → {d}", path.join(" → "));
                if seen.insert(d.clone()) {
                    let mut p = path.clone();
                    p.push(d.clone());
                    stack.push((d.clone(), p));
                }
            }
        }
    }
    let render: Vec<&String> = deps["render"].iter().collect();
    assert_eq!(render, ["camera", "raster", "scene"]);
}

/// Each library file's module path (`render/shadows/occlusion.rs` is render::shadows::occlusion,
/// a folder's `mod.rs` is the folder's module) and its code outside comments and unit tests.
fn files() -> Vec<(Vec<String>, String)> {
    fn walk(dir: &std::path::Path, module: &[String], out: &mut Vec<(Vec<String>, String)>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let path = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if path.is_dir() {
                if name != "cli" {
                    let mut m = module.to_vec();
                    m.push(name);
                    walk(&path, &m, out);
                }
                continue;
            }
            let Some(stem) = name.strip_suffix(".rs") else {
                continue;
            };
            if module.is_empty() && (stem == "lib" || stem == "main") {
                continue;
            }
            let mut m = module.to_vec();
            if stem != "mod" {
                m.push(stem.to_string());
            }
            let text = std::fs::read_to_string(&path).unwrap();
            let code = without_tests(&text);
            let code: Vec<&str> = code
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect();
            out.push((m, code.join("\n")));
        }
    }
    let mut out = Vec::new();
    walk(&root().join("src"), &[], &mut out);
    out
}

/// `text` up to its unit tests (`mod tests`). A `#[cfg(test)]` module declared above them (a
/// test-only helper file) is a file of its own, scanned as library code: it is.
fn without_tests(text: &str) -> &str {
    let at = [
        "#[cfg(test)]\nmod tests",
        "#[cfg(test)]\npub(super) mod tests",
    ]
    .iter()
    .filter_map(|m| text.find(m))
    .min();
    &text[..at.unwrap_or(text.len())]
}

/// The modules that path `rest` (what follows `crate::`, `super::` or `self::`, from module
/// `base`) names: the deepest module along it, for each item of a `{…}` group.
fn named(modules: &BTreeSet<Vec<String>>, base: Vec<String>, rest: &str) -> Vec<Vec<String>> {
    let (mut base, mut rest) = (base, rest.trim_start());
    while let Some(r) = rest.strip_prefix("super::") {
        base.pop();
        rest = r;
    }
    if let Some(group) = rest.strip_prefix('{') {
        // Items split at the group's own commas.
        let (mut depth, mut start, mut out) = (0, 0, Vec::new());
        for (i, c) in group.char_indices() {
            match c {
                '{' => depth += 1,
                '}' if depth == 0 => {
                    out.extend(named(modules, base.clone(), &group[start..i]));
                    return out;
                }
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    out.extend(named(modules, base.clone(), &group[start..i]));
                    start = i + 1;
                }
                _ => {}
            }
        }
        return out;
    }
    let ident: String = rest
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect();
    let mut next = base.clone();
    next.push(ident.clone());
    if ident != "self" && modules.contains(&next) {
        if let Some(after) = rest[ident.len()..].strip_prefix("::") {
            return named(modules, next, after);
        }
        return vec![next];
    }
    vec![base]
}

/// Each library file's imports of other files: `crate::`, `super::` and `self::` paths.
fn file_imports() -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let files = files();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut out = BTreeMap::new();
    for (module, code) in &files {
        let deps: &mut BTreeSet<Vec<String>> = out.entry(module.clone()).or_default();
        for (prefix, base) in [
            ("crate::", Vec::new()),
            ("super::", module[..module.len().saturating_sub(1)].to_vec()),
            ("self::", module.clone()),
        ] {
            for (i, _) in code.match_indices(prefix) {
                // A whole path, not the tail of another (`super::super::`, `x::self::`).
                let before = code[..i].chars().next_back();
                if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':') {
                    continue;
                }
                // A visibility, `pub(in crate::render)`, imports nothing.
                if code[..i].ends_with("(in ") {
                    continue;
                }
                for m in named(&modules, base.clone(), &code[i + prefix.len()..]) {
                    if &m != module {
                        deps.insert(m);
                    }
                }
            }
        }
        // And `use child::…`: a path from a name in scope, which for a file is one of its own
        // child modules (`mod.rs` importing its folder's files).
        for (i, _) in code.match_indices("use ") {
            let line_start = code[..i].rfind('\n').map_or(0, |n| n + 1);
            let lead = code[line_start..i].trim();
            if !(lead.is_empty() || lead.starts_with("pub")) {
                continue;
            }
            for m in named(&modules, module.clone(), &code[i + 4..]) {
                if &m != module {
                    deps.insert(m);
                }
            }
        }
    }
    out
}

#[test]
fn no_file_imports_one_that_imports_it_back() {
    let deps = file_imports();
    let name = |m: &Vec<String>| m.join("::");
    // The scan sees paths of every form: render's files import each other through `super::`.
    let render = |f: &str| vec!["render".to_string(), f.to_string()];
    assert!(deps[&render("drivers")].contains(&render("kernels")));
    assert!(deps[&vec!["render".into()]].contains(&render("drivers")));
    assert!(
        deps[&vec!["render".into(), "shadows".into(), "occlusion".into()]]
            .contains(&render("lanes"))
    );
    for start in deps.keys() {
        let mut stack = vec![(start.clone(), vec![name(start)])];
        let mut seen = BTreeSet::new();
        while let Some((m, path)) = stack.pop() {
            for d in deps.get(&m).into_iter().flatten() {
                assert!(d != start, "cycle: {} → {}", path.join(" → "), name(d));
                if seen.insert(d.clone()) {
                    let mut p = path.clone();
                    p.push(name(d));
                    stack.push((d.clone(), p));
                }
            }
        }
    }
    // lanes/ is a leaf of the renderer: its files import none of the renderer's but their own.
    for (m, d) in &deps {
        if m.starts_with(&render("lanes")) {
            let outside: Vec<_> = d
                .iter()
                .map(name)
                .filter(|d| d.starts_with("render") && !d.starts_with("render::lanes"))
                .collect();
            assert!(outside.is_empty(), "{}: {outside:?}", name(m));
        }
    }
}

/// Every `unsafe` block in the library says why it holds, on a `// SAFETY:` line just above it
/// (or above the expression or match arm that holds it).
#[test]
fn every_unsafe_block_has_its_own_safety_line() {
    let mut blocks = 0;
    for (module, _) in files() {
        // The file's own lines (comments kept), so the message points at the block.
        let text = std::fs::read_to_string(module_file(&module)).unwrap();
        let all: Vec<&str> = without_tests(&text).lines().collect();
        for (n, line) in all.iter().enumerate() {
            let code_part = line.split("//").next().unwrap();
            if !code_part.contains("unsafe {") {
                continue;
            }
            blocks += 1;
            let above = &all[n.saturating_sub(3)..n];
            assert!(
                above
                    .iter()
                    .any(|l| l.trim_start().starts_with("// SAFETY:")),
                "{}:{}: an unsafe block without a SAFETY line above it",
                module.join("/"),
                n + 1
            );
        }
    }
    assert!(
        blocks > 0,
        "no unsafe block found: is the scan still reading the renderer?"
    );
}

/// The file of module `module`: `a/b.rs`, or `a/b/mod.rs` for a folder.
fn module_file(module: &[String]) -> std::path::PathBuf {
    let src = root().join("src");
    let file = src.join(format!("{}.rs", module.join("/")));
    if file.exists() {
        file
    } else {
        src.join(module.join("/")).join("mod.rs")
    }
}
