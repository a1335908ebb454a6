//! The layer order ARCHITECTURE.md states, checked against the code: every `crate::<module>`
//! path in a file of `src/` names a module of a lower layer or the file's own.

use std::collections::BTreeMap;
use std::path::Path;

/// Layer of each top-level module, read from ARCHITECTURE.md's numbered list
/// (`    3. optimize, study, metrology — …`).
fn stated_layers() -> BTreeMap<String, usize> {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("ARCHITECTURE.md"))
            .unwrap();
    let mut layers = BTreeMap::new();
    for line in text.lines() {
        let Some((number, rest)) = line.trim_start().split_once(". ") else {
            continue;
        };
        let (Ok(layer), Some((names, _))) = (number.parse::<usize>(), rest.split_once(" — "))
        else {
            continue;
        };
        if !line.starts_with("    ") {
            continue;
        }
        for name in names.split(", ") {
            layers.insert(name.trim().to_string(), layer);
        }
    }
    layers
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The modules a line's code names as `crate::<module>` (comments skipped).
fn named_modules(line: &str) -> Vec<String> {
    let code = line.split("//").next().unwrap();
    code.match_indices("crate::")
        .map(|(i, m)| {
            code[i + m.len()..]
                .chars()
                .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                .collect()
        })
        .collect()
}

#[test]
fn every_import_goes_down_the_stated_layers() {
    let layers = stated_layers();
    assert!(
        layers.len() >= 10,
        "the layer list was not found: {layers:?}"
    );
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut against = Vec::new();
    let mut checked = 0;
    for file in files {
        let relative = file.strip_prefix(&src).unwrap();
        let first = relative.components().next().unwrap();
        let module = first.as_os_str().to_str().unwrap().trim_end_matches(".rs");
        if module == "main" || module == "lib" {
            continue;
        }
        let own = *layers
            .get(module)
            .unwrap_or_else(|| panic!("src/{module} has no layer in ARCHITECTURE.md"));
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, line) in text.lines().enumerate() {
            for dep in named_modules(line) {
                checked += 1;
                let theirs = *layers
                    .get(&dep)
                    .unwrap_or_else(|| panic!("crate::{dep} has no layer in ARCHITECTURE.md"));
                if dep != module && theirs >= own {
                    against.push(format!(
                        "{}:{}: {module} (layer {own}) imports {dep} (layer {theirs})",
                        relative.display(),
                        n + 1
                    ));
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} crate:: paths found");
    assert!(
        against.is_empty(),
        "imports against the layers:\n{}",
        against.join("\n")
    );
}

/// The check itself: a line importing upward is caught, comments are not read.
#[test]
fn the_reader_finds_modules_in_code_only() {
    assert_eq!(named_modules("use crate::physics::{A, B};"), ["physics"]);
    assert_eq!(
        named_modules("let x = crate::usecases::f(crate::surface::G); // crate::http"),
        ["usecases", "surface"]
    );
}
