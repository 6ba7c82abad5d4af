//! ARCHITECTURE.md's rules, checked on the source: no module imports one that imports it back,
//! render knows only camera, scene and raster, only `format` knows RON, and the library never
//! names the command line's crates.

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
    for module in ["document", "export", "render", "format", "sequence"] {
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
