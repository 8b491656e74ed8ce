//! Pins the emitters' output: the Rust, WGSL, GLSL, HLSL and C/C++ generated from the committed fixtures must
//! equal `tests/snapshots/*` byte for byte (`tests/emit.rs` compiles, validates and runs those
//! files). After an intended change to the generator, rewrite them with
//! `UPDATE_SNAPSHOTS=1 cargo test --test emit_snapshots` and review the diff.

use std::path::PathBuf;

use furnace::emit::{build_unit, emitter, EmitOptions, Lang, SourceFit, Unit};
use furnace::fit::file as fitfile;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn source(name: &str) -> SourceFit {
    let file =
        fitfile::read(&root().join("tests/fixtures").join(name)).unwrap_or_else(|e| panic!("{e}"));
    SourceFit::new(format!("tests/fixtures/{name}"), file, None).unwrap()
}

/// The units the snapshots pin.
fn units() -> Vec<Unit> {
    let (a, _) = build_unit(
        "paper-conductors",
        "FURNACE_PAPER_CONDUCTORS_GLSL",
        &[source("paper-conductors.json")],
        "furnace emit --fit tests/fixtures/paper-conductors.json --lang all",
        &EmitOptions::default(),
    )
    .unwrap();
    let (b, _) = build_unit(
        "dielectric-pair",
        "FURNACE_DIELECTRIC_PAIR_GLSL",
        &[
            source("ggx-dielectric.json"),
            source("ggx-dielectric-inv.json"),
        ],
        "furnace run --scene (a dielectric material; see tests/emit_snapshots.rs)",
        &EmitOptions::default(),
    )
    .unwrap();
    let (c, _) = build_unit(
        "aniso-conductor",
        "FURNACE_ANISO_CONDUCTOR_GLSL",
        &[source("ggx-conductor-aniso.json")],
        "furnace emit --fit tests/fixtures/ggx-conductor-aniso.json --lang all",
        &EmitOptions::default(),
    )
    .unwrap();
    vec![a, b, c]
}

fn generated() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for unit in units() {
        for lang in Lang::SOURCE {
            for a in emitter(lang).produce(&unit).unwrap() {
                out.push((a.file_name, String::from_utf8(a.bytes).unwrap()));
            }
        }
    }
    out
}

#[test]
fn generated_text_matches_the_snapshots() {
    let update = std::env::var_os("UPDATE_SNAPSHOTS").is_some();
    let mut stale = Vec::new();
    for (name, text) in generated() {
        let path = root().join("tests/snapshots").join(&name);
        if update {
            std::fs::write(&path, &text).unwrap();
            continue;
        }
        let want = std::fs::read_to_string(&path).unwrap_or_default();
        if want != text {
            stale.push(name);
        }
    }
    assert!(stale.is_empty(), "snapshots differ: {stale:?}; if the change is intended, run UPDATE_SNAPSHOTS=1 cargo test --test emit_snapshots and review the diff");
}

#[test]
fn generation_is_deterministic() {
    assert_eq!(generated(), generated());
}
