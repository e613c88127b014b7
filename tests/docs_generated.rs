//! The generated documentation pages: `docs/effects.md` is what `osiris effects --markdown` prints,
//! `docs/benchmarks.md` is what `osiris bench report` makes of the committed JSON lines in
//! `docs/benchmarks/`, and the report generator turns bench JSON into the expected table rows.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Runs the `osiris` binary; stdout on success, the panic message names stderr otherwise.
fn osiris(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_osiris"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "osiris {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Fails with the first differing line and the command that regenerates the page.
fn assert_page_current(page: &str, generated: &str, regenerate: &str) {
    let committed = std::fs::read_to_string(root().join(page))
        .unwrap_or_else(|e| panic!("{page}: {e}; create it with: {regenerate}"));
    if committed != generated {
        let line = committed
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .map_or_else(
                || committed.lines().count().min(generated.lines().count()) + 1,
                |i| i + 1,
            );
        panic!(
            "{page} is out of date (first difference at line {line}); regenerate it with:\n    \
             {regenerate}"
        );
    }
}

#[test]
fn effects_page_is_what_osiris_effects_prints() {
    let generated = osiris(&["effects", "--markdown"]);
    assert_page_current(
        "docs/effects.md",
        &generated,
        "cargo run -- effects --markdown > docs/effects.md",
    );
}

#[test]
fn effects_markdown_has_one_row_per_effect_with_its_default() {
    let md = osiris(&["effects", "--markdown"]);
    let rows: Vec<&str> = md.lines().filter(|l| l.starts_with("| `")).collect();
    let all = osiris_models::registry::catalogue();
    assert_eq!(rows.len(), all.len(), "one table row per effect");
    for (row, e) in rows.iter().zip(&all) {
        let state = if e.default_on { "on" } else { "off" };
        assert!(
            row.starts_with(&format!("| `{}` | {state} | ", e.name)),
            "{row}"
        );
        // Four columns: a `|` inside a formula must be escaped.
        let cells = row.replace("\\|", "").matches('|').count();
        assert_eq!(cells, 5, "{row}");
        if let Some(parent) = e.requires {
            assert!(row.contains(&format!("Requires `{parent}`.")), "{row}");
        }
    }
}

fn committed_bench_json() -> Vec<PathBuf> {
    let dir = root().join("docs/benchmarks");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    files
}

#[test]
fn benchmarks_page_is_the_report_of_the_committed_json() {
    let files = committed_bench_json();
    assert!(!files.is_empty(), "docs/benchmarks/*.json: none");
    let note = std::fs::read_to_string(root().join("docs/benchmarks/note.md")).unwrap();
    let mut args = vec!["bench", "report", "--note", note.as_str()];
    let names: Vec<String> = files
        .iter()
        .map(|f| {
            f.strip_prefix(root())
                .unwrap()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    // Paths relative to the repository root, as the regeneration command gives them.
    let abs: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    args.extend(abs.iter().map(String::as_str));
    let generated = osiris(&args);
    assert_page_current(
        "docs/benchmarks.md",
        &generated,
        &format!(
            "cargo run --release -- bench report --note \"$(cat docs/benchmarks/note.md)\" {} > \
             docs/benchmarks.md",
            names.join(" ")
        ),
    );
}

#[test]
fn bench_report_turns_json_lines_into_tables() {
    let dir = tempfile::tempdir().unwrap();
    let radar = dir.path().join("radar.json");
    std::fs::write(
        &radar,
        r#"{"bench":"radar","frames_per_s":63.2517,"threads":2,"paths":2000,"stages_ms":{"cfar":0.9,"doppler":1.125},"target":{"frames_per_s":20.0,"met":true},"machine":{"cpu_model":"Test CPU 9000","logical_cpus":16,"physical_cores":8,"default_threads":16,"simd":"avx2","profile":"release","load_avg_1min":0.5,"osiris_version":"0.1.0"}}
"#,
    )
    .unwrap();
    // Two lines in one file: the space bench lists its thread counts, the old line has no machine.
    let more = dir.path().join("more.json");
    std::fs::write(
        &more,
        r#"{"bench":"space","threads":[1,2],"build_s":0.000123456,"coherent_mrays_per_s":16.04,"machine":{"cpu_model":"Other CPU","logical_cpus":2,"physical_cores":null,"simd":"portable","profile":"release","load_avg_1min":1.93}}

{"bench":"fmu","camera_step_ms_100_objects":141.26,"note":"a|b"}
"#,
    )
    .unwrap();
    let md = osiris(&[
        "bench",
        "report",
        "--note",
        "Measured on a test machine.",
        radar.to_str().unwrap(),
        more.to_str().unwrap(),
    ]);
    let lines: Vec<&str> = md.lines().collect();
    let has = |l: &str| lines.contains(&l);
    assert!(md.starts_with("# Benchmarks\n"), "{md}");
    assert!(has("Measured on a test machine."), "{md}");
    // One section per JSON line, in input order, each with its machine and its rows.
    let sections: Vec<&str> = lines
        .iter()
        .copied()
        .filter(|l| l.starts_with("## "))
        .collect();
    assert_eq!(
        sections,
        [
            "## `osiris bench radar`",
            "## `osiris bench space`",
            "## `osiris bench fmu`",
            "## Not measured here"
        ],
        "{md}"
    );
    assert!(
        has(
            "Machine: Test CPU 9000, 16 logical CPUs (8 cores), threads: 2, release build, \
             avx2 kernels, load average 0.5 at the start, osiris 0.1.0."
        ),
        "{md}"
    );
    assert!(has("| `frames_per_s` | 63.25 |"), "{md}");
    assert!(has("| `paths` | 2000 |"), "{md}");
    assert!(has("| `stages_ms.cfar` | 0.9 |"), "{md}");
    assert!(has("| `stages_ms.doppler` | 1.125 |"), "{md}");
    assert!(has("| `target.frames_per_s` | 20 |"), "{md}");
    assert!(has("| `target.met` | true |"), "{md}");
    assert!(
        has(
            "Machine: Other CPU, 2 logical CPUs, threads: 1 and 2, release build, portable \
             kernels, load average 1.93 at the start."
        ),
        "{md}"
    );
    assert!(has("| `build_s` | 0.0001235 |"), "{md}");
    assert!(has("| `coherent_mrays_per_s` | 16.04 |"), "{md}");
    assert!(has("| `threads` | 1, 2 |"), "{md}");
    assert!(
        has("Machine: not recorded (a JSON line from before `machine` was added)."),
        "{md}"
    );
    assert!(has("| `camera_step_ms_100_objects` | 141.3 |"), "{md}");
    assert!(has("| `note` | a\\|b |"), "{md}");
    // `bench` and `machine` are not rows of the table.
    assert!(
        !md.contains("| `bench` |") && !md.contains("| `machine."),
        "{md}"
    );
    // The benchmarks with no line are named with the command that measures them.
    let missing = &md[md.find("## Not measured here").unwrap()..];
    for b in ["lidar", "camera", "consistency"] {
        assert!(
            missing.contains(&format!("`osiris bench {b}`: "))
                && missing.contains(&format!("bench {b} > docs/benchmarks/{b}.json")),
            "{b}: {missing}"
        );
    }
    for b in ["radar", "space", "fmu", "report"] {
        assert!(
            !missing.contains(&format!("`osiris bench {b}`")),
            "{b}: {missing}"
        );
    }
}

#[test]
fn bench_report_names_the_bad_line_and_needs_files() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"bench\":\"radar\"}\nnot json\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_osiris"))
        .args(["bench", "report", bad.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.json:2"), "{err}");

    let out = Command::new(env!("CARGO_BIN_EXE_osiris"))
        .args(["bench", "report"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("docs/benchmarks/*.json"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
