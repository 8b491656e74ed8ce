//! The README's examples work in a fresh clone: every command in its `sh` blocks runs as
//! written, in order, in a copy of the repository whose folder has no siblings, and every
//! subcommand of `furnace` has an example. The set-up block holds exactly the two set-up
//! commands (`tests/standalone.rs` runs the first one at small sizes).

mod common;

use clap::CommandFactory;
use std::time::Instant;

/// The commands of the README's fenced `sh` blocks, one per block, with `\` continuations
/// joined; blank lines and comment lines are dropped.
fn sh_blocks(markdown: &str) -> Vec<Vec<String>> {
    let mut blocks = Vec::new();
    let mut current: Option<Vec<String>> = None;
    let mut pending = String::new();
    for line in markdown.lines() {
        let trimmed = line.trim();
        match current.as_mut() {
            None if trimmed == "```sh" => current = Some(Vec::new()),
            None => {}
            Some(_) if trimmed == "```" => {
                assert!(pending.is_empty(), "a `\\` continuation runs off its block");
                blocks.push(current.take().unwrap());
            }
            Some(cmds) => {
                if let Some(head) = line.strip_suffix('\\') {
                    pending.push_str(head);
                    pending.push(' ');
                    continue;
                }
                pending.push_str(line);
                let cmd = std::mem::take(&mut pending);
                let cmd = cmd.trim();
                if !cmd.is_empty() && !cmd.starts_with('#') {
                    cmds.push(cmd.to_string());
                }
            }
        }
    }
    assert!(current.is_none(), "an ```sh block is not closed");
    blocks
}

/// The command without its trailing `# comment`.
fn without_comment(cmd: &str) -> &str {
    cmd.split(" #").next().unwrap().trim()
}

fn readme() -> String {
    std::fs::read_to_string(common::repository().join("README.md")).unwrap()
}

#[test]
fn the_set_up_block_is_the_two_set_up_commands() {
    let blocks = sh_blocks(&readme());
    let setup: Vec<&str> = blocks[0].iter().map(|c| without_comment(c)).collect();
    assert_eq!(
        setup,
        ["cargo run --release -- run", "cargo test --release"],
        "the README's first sh block must be the two set-up commands"
    );
    let ci = std::fs::read_to_string(common::repository().join(".ci/run")).unwrap();
    assert!(
        ci.lines().any(|l| l.trim() == "cargo test --release"),
        ".ci/run must call the README's test command"
    );
}

#[test]
fn every_readme_example_runs_in_a_fresh_clone() {
    let blocks = sh_blocks(&readme());
    let dir = common::fresh_copy("readme");
    let mut ran = Vec::new();
    for cmd in blocks.iter().skip(1).flatten() {
        let bare = without_comment(cmd);
        if let Some(example) = bare.strip_prefix("cargo run --release --example ") {
            // Cargo.toml builds and runs it as a test of `cargo test`.
            let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
            assert!(
                dir.join("examples").join(format!("{example}.rs")).is_file()
                    && manifest.contains(&format!("name = \"{example}\"\ntest = true")),
                "README runs example {example}: it must exist and be declared with test = true"
            );
            continue;
        }
        assert!(
            bare.starts_with("furnace "),
            "README example `{cmd}`: only furnace commands and tested examples are allowed"
        );
        let start = Instant::now();
        let o = common::shell(cmd, &dir);
        assert!(
            o.status.success(),
            "README example failed in a fresh clone: `{cmd}`\n{}",
            common::text(&o)
        );
        eprintln!("{:6.2} s  {bare}", start.elapsed().as_secs_f64());
        ran.push(bare.to_string());
    }
    // Every subcommand (and every benchmark) has an example.
    let cli = furnace::cli::Cli::command();
    for sub in cli.get_subcommands() {
        let name = sub.get_name();
        let nested: Vec<String> = sub
            .get_subcommands()
            .map(|s| format!("{name} {}", s.get_name()))
            .collect();
        let wanted = if nested.is_empty() {
            vec![name.to_string()]
        } else {
            nested
        };
        for w in wanted {
            assert!(
                ran.iter().any(
                    |c| c == &format!("furnace {w}") || c.starts_with(&format!("furnace {w} "))
                ),
                "the README has no example of `furnace {w}`"
            );
        }
    }
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}
