//! `firn bench --sweep`: tiny particle and grid sweeps write their table,
//! CSV, JSON and two charts; a memory budget that nothing fits in skips every
//! size cleanly; the charts plot exactly the measured records.

use std::collections::HashSet;
use std::fs;
use std::path::Path;

// The chart code itself, to check what it plots without reading pixels.
#[allow(dead_code)]
#[path = "../src/charts.rs"]
mod charts;

use charts::{CHART_SIZE, Sample, build_series};

mod common;
use common::{firn, text};

/// `firn bench --sweep KIND --transfer apic --sweep-out OUT` plus `extra`;
/// asserts it succeeded and returns its standard output.
fn sweep(kind: &str, out: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "bench",
        "--sweep",
        kind,
        "--transfer",
        "apic",
        "--sweep-out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let output = firn(&args);
    assert!(
        output.status.success(),
        "firn {args:?} failed\nstdout: {}\nstderr: {}",
        text(&output.stdout),
        text(&output.stderr)
    );
    text(&output.stdout)
}

fn records(out: &Path, kind: &str) -> Vec<serde_json::Value> {
    let json = fs::read_to_string(out.join(format!("sweep-{kind}.json"))).unwrap();
    serde_json::from_str::<serde_json::Value>(&json)
        .unwrap()
        .as_array()
        .expect("the JSON is an array of records")
        .clone()
}

fn csv_lines(out: &Path, kind: &str) -> Vec<String> {
    fs::read_to_string(out.join(format!("sweep-{kind}.csv")))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

/// The chart samples of the records, as the sweep builds them: x is the
/// particle count or the cell count, y the substeps per second.
fn samples(kind: &str, records: &[serde_json::Value]) -> Vec<Sample> {
    records
        .iter()
        .map(|record| Sample {
            series: record["transfer"].as_str().unwrap().to_string(),
            x: match kind {
                "particles" => record["particles"]
                    .as_f64()
                    .or(record["target_particles"].as_f64())
                    .unwrap(),
                _ => record["cells"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|n| n.as_f64().unwrap())
                    .product(),
            },
            y: record["substeps_per_second"].as_f64(),
        })
        .collect()
}

/// Asserts the PNG decodes at the chart size and is not blank.
fn assert_chart(path: &Path) {
    let image = image::open(path)
        .unwrap_or_else(|error| panic!("{}: {error}", path.display()))
        .to_rgb8();
    assert_eq!(image.dimensions(), CHART_SIZE, "{}", path.display());
    let colours: HashSet<[u8; 3]> = image.pixels().map(|pixel| pixel.0).collect();
    assert!(
        colours.len() > 16,
        "{} has only {} colours",
        path.display(),
        colours.len()
    );
}

/// The CSV, JSON and charts of a sweep over `sizes` with every size fitting.
fn assert_outputs(out: &Path, kind: &str, sizes: usize) {
    let lines = csv_lines(out, kind);
    assert_eq!(lines.len(), 1 + sizes, "{lines:#?}");
    assert!(lines[0].starts_with("sweep,transfer,size,"));
    assert!(lines[0].contains("ns_per_particle_substep"));
    assert!(lines[0].contains("measured_peak_bytes,fits,note"));
    let records = records(out, kind);
    assert_eq!(records.len(), sizes);
    for record in &records {
        assert_eq!(record["fits"], true);
        assert!(record["particles"].as_u64().unwrap() > 0);
        assert!(record["substeps"].as_u64().unwrap() > 0);
        assert!(record["substeps_per_second"].as_f64().unwrap() > 0.0);
        assert!(record["ns_per_particle_substep"].as_f64().unwrap() > 0.0);
        assert!(record["estimated_peak_bytes"].as_u64().unwrap() > 0);
        assert_eq!(record["grid_nodes"].as_array().unwrap().len(), 3);
        if cfg!(target_os = "linux") {
            assert!(record["measured_peak_bytes"].as_u64().unwrap() > 0);
            assert!(record["cpu_seconds"].as_f64().is_some());
        }
    }
    let series = build_series(&samples(kind, &records));
    let points: usize = series.iter().map(|line| line.points.len()).sum();
    assert_eq!(points, sizes, "one point per measured record");
    for chart in ["substeps", "ns"] {
        assert_chart(&out.join(format!("sweep-{kind}-{chart}.png")));
    }
}

#[test]
fn a_tiny_particle_sweep_writes_csv_json_and_two_charts() {
    let dir = tempfile::tempdir().unwrap();
    let stdout = sweep(
        "particles",
        dir.path(),
        &["--sizes", "512,1024", "--steps", "2", "--warmup", "1"],
    );
    assert!(stdout.contains("2^9"), "{stdout}");
    assert!(stdout.contains("2^10"), "{stdout}");
    assert_outputs(dir.path(), "particles", 2);
    let records = records(dir.path(), "particles");
    assert_eq!(records[0]["target_particles"], 512);
    assert_eq!(records[0]["cells"], serde_json::json!([256, 256, 256]));
    // Sampled from a ball: near the asked count, not exactly it.
    let sampled = records[1]["particles"].as_f64().unwrap();
    assert!((sampled / 1024.0 - 1.0).abs() < 0.2, "{sampled}");
}

#[test]
fn a_tiny_grid_sweep_writes_csv_json_and_two_charts() {
    let dir = tempfile::tempdir().unwrap();
    sweep(
        "grid",
        dir.path(),
        &["--sizes", "16,32", "--steps", "2", "--warmup", "1"],
    );
    assert_outputs(dir.path(), "grid", 2);
    let records = records(dir.path(), "grid");
    assert_eq!(records[1]["cells"], serde_json::json!([32, 32, 32]));
    // 32 cells + 1 node + 3 padding nodes on each side, in blocks of 4.
    assert_eq!(records[1]["grid_nodes"], serde_json::json!([40, 40, 40]));
    assert_eq!(records[1]["grid_nodes_total"], 64_000);
}

#[test]
fn a_memory_budget_nothing_fits_in_skips_every_size_and_still_writes_the_csv() {
    let dir = tempfile::tempdir().unwrap();
    let stdout = sweep("grid", dir.path(), &["--memory-budget", "0.0001"]);
    let lines = csv_lines(dir.path(), "grid");
    assert_eq!(lines.len(), 1 + 4, "{lines:#?}");
    let records = records(dir.path(), "grid");
    assert_eq!(records.len(), 4);
    for record in &records {
        assert_eq!(record["fits"], false);
        assert!(record["substeps_per_second"].is_null());
        let note = record["note"].as_str().unwrap();
        assert!(note.ends_with("— skipped"), "{note}");
        assert!(note.contains("needs"), "{note}");
    }
    assert!(
        stdout
            .contains("512x512x256: needs 26.1 MiB, 0.1 MiB available (--memory-budget) — skipped"),
        "{stdout}"
    );
    assert!(
        build_series(&samples("grid", &records))
            .iter()
            .all(|line| line.points.is_empty())
    );
    assert!(!dir.path().join("sweep-grid-substeps.png").exists());
}

#[test]
fn the_series_hold_the_measured_samples_by_scheme() {
    let sample = |series: &str, x: f64, y: Option<f64>| Sample {
        series: series.into(),
        x,
        y,
    };
    let series = build_series(&[
        sample("apic", 4096.0, Some(20.0)),
        sample("pic-flip", 1024.0, Some(30.0)),
        sample("apic", 1024.0, Some(40.0)),
        sample("apic", 8192.0, None),
        sample("pic-flip", 2048.0, Some(f64::NAN)),
    ]);
    assert_eq!(series.len(), 2);
    assert_eq!(series[0].name, "apic");
    assert_eq!(series[0].points, vec![(1024.0, 40.0), (4096.0, 20.0)]);
    assert_eq!(series[1].points, vec![(1024.0, 30.0)]);
}

#[test]
fn unreadable_sizes_are_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let output = firn(&[
        "bench",
        "--sweep",
        "grid",
        "--sizes",
        "64x64",
        "--sweep-out",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(text(&output.stderr).contains("--sizes"));
}
