//! `furnace tabulate --shard K/N` and `furnace merge`: four shards merged are the single run's
//! files byte for byte, and missing, foreign or damaged shards are refused.

mod common;

use common::{furnace, scratch};
use std::process::Output;

fn ok(o: &Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err
}

fn failed(o: &Output) -> String {
    assert!(!o.status.success(), "unexpected success");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Tabulates `model` at `resolution` once and in four shards merged; the files must be equal.
fn four_shards_merge_to_the_single_run(model: &str, resolution: &str) {
    let name = format!("{model}-{resolution}");
    let (single, sharded) = (scratch(&format!("{name}-1")), scratch(&format!("{name}-4")));
    ok(&furnace(
        &["tabulate", "--model", model, "--resolution", resolution],
        &single,
    ));
    for k in 0..4 {
        let shard = format!("{k}/4");
        let args = [
            "tabulate",
            "--model",
            model,
            "--resolution",
            resolution,
            "--shard",
            &shard,
        ];
        ok(&furnace(&args, &sharded));
    }
    let merge = [
        "merge",
        "--model",
        model,
        "--resolution",
        resolution,
        "--shards",
        "4",
    ];
    ok(&furnace(&merge, &sharded));
    for ext in ["f64", "exr", "json"] {
        let file = format!("data/{model}/{resolution}.{ext}");
        let a = std::fs::read(single.join(&file)).unwrap();
        let b = std::fs::read(sharded.join(&file)).unwrap();
        assert!(
            a == b,
            "{file} differs between the single run and the merge"
        );
    }
    // the merged table is the cache a later request reads
    let again = ok(&furnace(
        &["tabulate", "--model", model, "--resolution", resolution],
        &sharded,
    ));
    assert!(again.contains("read from cache"), "{again}");
}

#[test]
fn four_dimensional_shards_merge_byte_identically() {
    four_shards_merge_to_the_single_run("ggx-conductor-aniso", "6x3x5x3");
}

#[test]
fn two_dimensional_shards_merge_byte_identically() {
    four_shards_merge_to_the_single_run("ggx-conductor", "9x7");
}

#[test]
fn missing_foreign_and_damaged_shards_are_refused() {
    let d = scratch("refused");
    let model = "ggx-conductor";
    for k in 0..2 {
        let shard = format!("{k}/2");
        ok(&furnace(
            &[
                "tabulate",
                "--model",
                model,
                "--resolution",
                "6",
                "--shard",
                &shard,
            ],
            &d,
        ));
    }
    let merge = |n: &str, extra: &[&str]| {
        let mut args = vec![
            "merge",
            "--model",
            model,
            "--resolution",
            "6",
            "--shards",
            n,
        ];
        args.extend_from_slice(extra);
        furnace(&args, &d)
    };
    let e = failed(&merge("3", &[]));
    assert!(
        e.contains("shard 0/3 is missing") && e.contains("--shard 0/3"),
        "{e}"
    );
    let e = failed(&merge("2", &["--order", "14"]));
    assert!(e.contains("another request"), "{e}");
    let bin = d.join("data/ggx-conductor/6x6.shard-1-of-2.bin");
    let mut bytes = std::fs::read(&bin).unwrap();
    bytes[3] ^= 1;
    std::fs::write(&bin, &bytes).unwrap();
    let e = failed(&merge("2", &[]));
    assert!(e.contains("shard 1/2 is damaged"), "{e}");
    let json = d.join("data/ggx-conductor/6x6.shard-1-of-2.json");
    let text = std::fs::read_to_string(&json).unwrap();
    std::fs::write(&json, text.replace("\"shard\": 1", "\"shard\": 0")).unwrap();
    let e = failed(&merge("2", &[]));
    assert!(e.contains("another request"), "{e}");
    assert!(
        !d.join("data/ggx-conductor/6x6.f64").exists(),
        "nothing merged"
    );
    let e = failed(&furnace(
        &["tabulate", "--model", model, "--shard", "2/2"],
        &d,
    ));
    assert!(e.contains("K must be below N"), "{e}");
}
