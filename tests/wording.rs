//! The product speaks of itself only: no development history or process words in the README,
//! docs/, the sources (comments and `--help` texts), the tests or the generated reports.

use std::path::{Path, PathBuf};

/// Case-insensitive, anywhere in a line: words of how the product was made, and process words
/// that should read as product words (plus "issue" followed by a digit, checked below). Each is
/// spelt in two pieces so that this file passes its own test.
const FORBIDDEN: &[&str] = &[
    concat!("ses", "sion"),
    concat!("ag", "ent"),
    concat!("the is", "sue"),
    concat!("main ", "job"),
];

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else if p
            .extension()
            .is_some_and(|x| x == "rs" || x == "md" || x == "toml")
        {
            out.push(p);
        }
    }
}

#[test]
fn no_development_history_in_the_product() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut paths = vec![root.join("README.md")];
    for d in ["docs", "src", "tests", "examples", "reports"] {
        files(&root.join(d), &mut paths);
    }
    let mut found = Vec::new();
    for path in &paths {
        let text = std::fs::read_to_string(path).unwrap();
        for (n, line) in text.lines().enumerate() {
            let lower = line.to_lowercase();
            let issue_number = lower.match_indices(concat!("is", "sue ")).any(|(i, m)| {
                lower[i + m.len()..]
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_ascii_digit())
            });
            if issue_number || FORBIDDEN.iter().any(|w| lower.contains(w)) {
                let rel = path.strip_prefix(&root).unwrap().display();
                found.push(format!("{rel}:{}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "development history or process words:\n{}",
        found.join("\n")
    );
}
