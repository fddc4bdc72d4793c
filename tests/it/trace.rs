//! `--trace`: the Chrome trace-event file is valid JSON in the documented
//! format, every GPU pass lies inside its submission (and each submission
//! between its CPU submit and its fence), the labels reach the validation
//! layer, the report's per-pass figures add up to the printed table, the
//! rayon workers' spans lie on their own tracks inside their stages, and
//! with tracing and profiling off nothing is written for them.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use serde_json::Value;
use vkrad::app::{run, Job, Report};
use vkrad::gpu::instrument::Counters;
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::trace::{cat, Trace, GPU_TID};

use crate::common::{self, assert_validation_clean};

fn device_with(trace: Option<Arc<Trace>>, profile: bool) -> Arc<Device> {
    let device = Device::new(&DeviceOptions {
        selector: std::env::var("VKRAD_TEST_DEVICE").ok(),
        validate: true,
        profile,
        trace,
        capture: None,
    })
    .expect("a Vulkan device");
    if std::env::var_os("VKRAD_REQUIRE_VALIDATION").is_some() {
        assert!(device.validation_enabled());
    }
    device
}

fn temp_dir(name: &str) -> common::Scratch {
    common::Scratch::new(&format!("trace-{name}"))
}

/// A small whole job: the `simple` scene, gathered, a small image.
fn small_job(dir: &Path, trace: Option<Arc<Trace>>) -> Job {
    let mut job = Job::new("simple");
    job.output = Some(dir.join("simple.png"));
    job.size = (48, 48);
    // What the display mesh shows (the pixels' own test is `pixels`).
    job.shade = vkrad::gather::pixels::Shade::Mesh;
    job.device.trace = trace;
    job
}

fn run_job(job: &Job, device: &Arc<Device>) -> Report {
    let report = run(job, Some(device.clone()), |_| true).expect("the job runs");
    assert_validation_clean(device);
    report
}

fn num(e: &Value, key: &str) -> f64 {
    e[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number in {e}"))
}

/// Checks the documented format and returns the "X" events.
fn check_format(trace: &Value) -> Vec<Value> {
    let events = trace["traceEvents"].as_array().expect("traceEvents");
    assert!(trace["otherData"]["gpu_clock"].is_string());
    let mut complete = Vec::new();
    for e in events {
        let ph = e["ph"].as_str().expect("ph");
        assert!(e["pid"].is_u64() && e["tid"].is_u64(), "{e}");
        assert!(e["name"].is_string(), "{e}");
        assert!(e["args"].is_object(), "{e}");
        match ph {
            "M" => {
                assert!(
                    ["process_name", "thread_name", "thread_sort_index"]
                        .contains(&e["name"].as_str().unwrap()),
                    "{e}"
                );
                // Chrome's own parser (DevTools' TracingModel) needs a cat.
                assert_eq!(e["cat"], "__metadata", "{e}");
            }
            "X" => {
                assert!(e["cat"].is_string(), "{e}");
                assert!(num(e, "ts").is_finite() && num(e, "ts") >= 0.0, "{e}");
                assert!(num(e, "dur") >= 0.0, "negative duration: {e}");
                complete.push(e.clone());
            }
            other => panic!("event type {other:?} is not in the documented format: {e}"),
        }
    }
    complete
}

/// Every GPU pass and shot lies within its submission; a calibrated
/// submission lies between its CPU submit and the CPU seeing its fence.
/// Returns the number of each pass kind.
fn check_gpu_spans(events: &[Value]) -> BTreeMap<String, u64> {
    let of = |c: &'static str| events.iter().filter(move |e| e["cat"] == c);
    let submissions: BTreeMap<u64, &Value> = of(cat::SUBMISSION)
        .map(|e| (e["args"]["submission"].as_u64().unwrap(), e))
        .collect();
    assert!(!submissions.is_empty());
    // A microsecond of slack for the JSON's rounding, plus the calibration's.
    let slack = |s: &Value| 1e-3 + s["args"]["calibration_error_us"].as_f64().unwrap_or(0.0);
    for s in submissions.values() {
        assert_eq!(s["tid"], GPU_TID);
        if s["args"]["clock"] == "calibrated" {
            let (a, b) = (num(s, "ts"), num(s, "ts") + num(s, "dur"));
            let e = slack(s);
            assert!(
                a >= num(&s["args"], "cpu_submit_us") - e,
                "the GPU started before it was submitted: {s}"
            );
            assert!(
                b <= num(&s["args"], "cpu_signalled_us") + e,
                "the GPU ended after the CPU saw its fence: {s}"
            );
        }
    }
    let mut passes = BTreeMap::new();
    for e in of(cat::PASS).chain(of(cat::SHOT)) {
        let s = submissions[&e["args"]["submission"].as_u64().expect("submission id")];
        let (a, b) = (num(e, "ts"), num(e, "ts") + num(e, "dur"));
        let (sa, sb) = (num(s, "ts"), num(s, "ts") + num(s, "dur"));
        assert!(
            a >= sa - 1e-3 && b <= sb + 1e-3,
            "{e} is outside its submission {s}"
        );
        assert_eq!(e["tid"], GPU_TID);
        if e["cat"] == cat::PASS {
            *passes
                .entry(e["name"].as_str().unwrap().to_string())
                .or_insert(0) += 1;
        }
    }
    passes
}

#[test]
fn a_traced_run_is_a_valid_chrome_trace_with_every_pass_inside_its_submission() {
    let dir = temp_dir("run");
    let trace = Arc::new(Trace::new());
    let device = device_with(Some(trace.clone()), false);
    let report = run_job(&small_job(&dir, Some(trace.clone())), &device);
    // Through text, as a viewer reads it.
    let text = serde_json::to_string(&trace.to_json()).unwrap();
    let parsed: Value = serde_json::from_str(&text).expect("valid JSON");
    let events = check_format(&parsed);
    let stages: Vec<&str> = events
        .iter()
        .filter(|e| e["cat"] == cat::STAGE)
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    for stage in [
        "load",
        "mesh",
        "solve",
        "display mesh",
        "gather",
        "render",
        "write",
    ] {
        assert!(stages.contains(&stage), "no stage {stage} in {stages:?}");
    }
    let passes = check_gpu_spans(&events);
    // Every GPU pass of the run is there: the ones the report times.
    for (stage, (count, _)) in &report.gpu_times.stages {
        if !stage.contains("(CPU") {
            assert_eq!(passes.get(*stage), Some(count), "pass {stage}");
        }
    }
    assert_eq!(passes["shooting"], report.solution.shots as u64);
    // Each shot and batch carries its ids and its shooter's figures.
    let shots: Vec<&Value> = events.iter().filter(|e| e["cat"] == cat::SHOT).collect();
    assert_eq!(shots.len(), report.solution.shots);
    for s in &shots {
        let a = &s["args"];
        assert_eq!(s["name"], format!("shot {}", a["shot"]));
        assert!(a["resolution"].as_u64().unwrap() >= 32);
        assert!(a["shooter_elements"].as_u64().unwrap() >= 1);
        assert_eq!(a["receivers"], report.mesh.elements.len());
    }
    let batch_cpu: Vec<&str> = events
        .iter()
        .filter(|e| e["cat"] == cat::BATCH_CPU && e["args"]["batch"] == 0)
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    for step in ["pick", "record", "submit", "wait", "readback"] {
        assert!(batch_cpu.contains(&step), "batch 0 has no {step}");
    }
    assert!(Counters::get(&device.counters.timestamps) > 0);
    if device.calibrator_extension().is_some() {
        assert!(Counters::get(&device.counters.calibrations) > 0);
        assert!(parsed["otherData"]["gpu_clock"]
            .as_str()
            .unwrap()
            .starts_with("calibrated"));
    }
}

#[test]
fn with_trace_and_profile_off_no_timestamp_or_trace_event_is_written() {
    let dir = temp_dir("off");
    let device = device_with(None, false);
    let report = run_job(&small_job(&dir, None), &device);
    assert!(device.trace.is_none());
    let c = &device.counters;
    assert_eq!(Counters::get(&c.timestamps), 0);
    assert_eq!(Counters::get(&c.statistics), 0);
    assert_eq!(Counters::get(&c.calibrations), 0);
    assert_eq!(Counters::get(&c.submission_ids), 0);
    assert!(!report.gpu_times.gpu);
    assert!(report.gpu_times.stats.is_empty());
}

#[test]
fn the_validation_layer_sees_the_pass_and_shot_labels() {
    let device = device_with(None, false);
    if !device.validation_enabled() {
        eprintln!("skipped: no validation layer");
        return;
    }
    // Every pass of a run opens a label.
    let before = Counters::get(&device.counters.labels);
    let dir = temp_dir("labels");
    let report = run_job(&small_job(&dir, None), &device);
    let opened = Counters::get(&device.counters.labels) - before;
    assert!(
        opened as usize >= 5 * report.solution.shots,
        "{opened} labels for {} shots",
        report.solution.shots
    );
    // An error inside them names both.
    vkrad::gpu::profiler::record_labelled_fault(&device).unwrap();
    let errors = device.validation_errors();
    assert!(
        errors
            .iter()
            .any(|e| e.contains("[command-buffer labels: shot probe > hemicube render]")),
        "{errors:#?}"
    );
}

/// The `--profile` table's rows: pass -> (count, total s, mean ms).
fn printed_table(stdout: &str) -> BTreeMap<String, (u64, f64, f64)> {
    let mut rows = BTreeMap::new();
    let mut inside = false;
    for line in stdout.lines() {
        if line.starts_with("  passes") {
            inside = true;
            continue;
        }
        if inside && !line.starts_with("    ") {
            break;
        }
        if !inside || line.trim_start().starts_with("pass ") {
            continue;
        }
        let tokens: Vec<&str> = line.split_whitespace().collect();
        let n = tokens.len();
        let name = tokens[..n - 4].join(" ");
        rows.insert(
            name,
            (
                tokens[n - 4].parse().unwrap(),
                tokens[n - 3].parse().unwrap(),
                tokens[n - 2].parse().unwrap(),
            ),
        );
    }
    rows
}

#[test]
fn the_cli_writes_a_trace_and_the_reports_pass_figures_add_up_to_the_printed_table() {
    let dir = temp_dir("cli");
    let out = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args([
            "profile",
            "simple",
            "--size",
            "32x32",
            "--validate",
            "--trace",
            "t.json",
            "--report",
            "r.json",
        ])
        .current_dir(&dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let trace: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("t.json")).unwrap()).unwrap();
    check_gpu_spans(&check_format(&trace));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("r.json")).unwrap()).unwrap();
    let table = printed_table(&stdout);
    let passes = report["timing"]["passes"].as_array().unwrap();
    assert!(!table.is_empty(), "{stdout}");
    assert_eq!(passes.len(), table.len(), "{stdout}");
    let (mut report_sum, mut table_sum) = (0.0, 0.0);
    for p in passes {
        let name = p["pass"].as_str().unwrap();
        let &(count, total, mean) = table.get(name).unwrap_or_else(|| panic!("{name}"));
        let t = num(p, "total_s");
        assert_eq!(p["count"].as_u64(), Some(count), "{name}");
        assert!(
            (t - total).abs() <= 0.0005 + 1e-9,
            "{name}: {t} against {total}"
        );
        assert!((num(p, "mean_ms") - mean).abs() <= 0.00005 + 1e-9, "{name}");
        let (min, max, median) = (num(p, "min_ms"), num(p, "max_ms"), num(p, "median_ms"));
        assert!(min <= median && median <= max, "{name}");
        let total_ms = 1e3 * t;
        let n = count as f64;
        assert!(min * n <= total_ms * (1.0 + 1e-9) && total_ms <= max * n * (1.0 + 1e-9) + 1e-9);
        report_sum += t;
        table_sum += total;
    }
    assert!((report_sum - table_sum).abs() <= 0.0005 * passes.len() as f64);
    assert_eq!(report["timing"]["source"], "gpu-timestamps");
}

/// The stages a rayon span of each name lies in.
fn stages_of(span: &str) -> &'static [&'static str] {
    match span {
        "shaft culling" => &["mesh", "display mesh"],
        "element-centre pass" | "gather points" => &["gather"],
        other => panic!("a rayon span of no known stage: {other}"),
    }
}

#[test]
fn rayon_work_is_traced_per_worker_on_its_own_track_inside_its_stage() {
    let dir = temp_dir("rayon");
    let out = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args([
            "profile", "simple", "--size", "32x32", "--shade", "mesh", "--trace", "t.json",
        ])
        .env("RAYON_NUM_THREADS", "2")
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.join("t.json")).unwrap();
    let trace: Value = serde_json::from_str(&text).expect("valid JSON");
    let events = check_format(&trace);
    let track_names: BTreeMap<u64, &str> = trace["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["name"] == "thread_name")
        .map(|e| {
            (
                e["tid"].as_u64().unwrap(),
                e["args"]["name"].as_str().unwrap(),
            )
        })
        .collect();
    let stages: Vec<&Value> = events.iter().filter(|e| e["cat"] == cat::STAGE).collect();
    let rayon: Vec<&Value> = events.iter().filter(|e| e["cat"] == cat::RAYON).collect();
    let mut tracks = BTreeMap::new();
    for e in &rayon {
        let name = e["name"].as_str().unwrap();
        let tid = e["tid"].as_u64().unwrap();
        assert!(
            track_names
                .get(&tid)
                .is_some_and(|t| t.starts_with("CPU rayon worker")),
            "{e} is not on a rayon worker's track: {track_names:?}"
        );
        *tracks.entry(tid).or_insert(0) += 1;
        let (a, b) = (num(e, "ts"), num(e, "ts") + num(e, "dur"));
        assert!(
            stages.iter().any(|s| {
                stages_of(name).contains(&s["name"].as_str().unwrap())
                    && a >= num(s, "ts") - 1e-3
                    && b <= num(s, "ts") + num(s, "dur") + 1e-3
            }),
            "{e} lies in none of its stages {:?}",
            stages_of(name)
        );
        let args = &e["args"];
        assert!(num(args, "busy_us") <= num(e, "dur") + 1e-3, "{e}");
        let (pieces, items) = (
            args["pieces"].as_u64().unwrap(),
            args["items"].as_u64().unwrap(),
        );
        assert!(pieces >= 1 && items >= pieces, "{e}");
    }
    for name in ["shaft culling", "element-centre pass", "gather points"] {
        assert!(rayon.iter().any(|e| e["name"] == name), "no {name} span");
    }
    assert!(
        tracks.len() >= 2,
        "two rayon threads, but their spans are on {tracks:?}"
    );
    // Every element-centre point of every pass is counted once.
    let elements = stages.iter().find(|s| s["name"] == "mesh").unwrap()["args"]["elements"]
        .as_u64()
        .unwrap();
    let centres: u64 = rayon
        .iter()
        .filter(|e| e["name"] == "element-centre pass")
        .map(|e| e["args"]["items"].as_u64().unwrap())
        .sum();
    assert!(
        centres > 0 && centres % elements == 0,
        "{centres} points, {elements} elements"
    );
}

#[test]
fn capture_without_renderdoc_says_what_is_missing() {
    let dir = temp_dir("capture");
    let out = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args(["profile", "simple", "--size", "16x16", "--capture", "0"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    if out.status.success() {
        // RenderDoc is installed here: the capture was made or said why not.
        assert!(stdout.contains("  capture   shot 0's batch"), "{stdout}");
        return;
    }
    if stderr.contains("no Vulkan device can run vkrad (needs Vulkan 1.3") {
        // RenderDoc is installed and loaded, and its layer lowers the
        // device's version below vkrad's (Debian's RenderDoc 1.24 makes
        // lavapipe 1.2): a clear error, before any work.
        assert!(!dir.join("simple.png").exists());
        return;
    }
    assert!(
        stderr.contains("RenderDoc's in-application API is not loadable")
            && stderr.contains("librenderdoc.so")
            && stderr.contains("LD_LIBRARY_PATH"),
        "{stderr}"
    );
    // Refused before any work: no image.
    assert!(!dir.join("simple.png").exists());
}
