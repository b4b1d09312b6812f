//! `haptic6d run --device emulator|udp|haply` and `haptic6d stability` end to end: the
//! closed-loop run writes its outputs and reports the device, a live device with nothing there
//! runs released or says why on one line, the study finds the plate's bound, bad names are
//! refused on one line.

mod common;

use common::haptic6d;

/// `haptic6d run plate --device DEVICE [extra] --out DIR/run --no-plots --json
/// --no-rt-priority` in a fresh folder named by `tag`: the folder (remove it when done), the
/// run's folder and its JSON summary.
fn run_plate(
    tag: &str,
    device: &str,
    extra: &[&str],
) -> (std::path::PathBuf, std::path::PathBuf, serde_json::Value) {
    let d = std::env::temp_dir().join(format!("haptic6d-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    let out = d.join("run");
    let mut args = vec!["run", "plate", "--device", device];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", out.to_str().unwrap(), "--no-plots", "--json"]);
    args.push("--no-rt-priority");
    let o = haptic6d(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = serde_json::from_slice(&o.stdout).unwrap();
    (d, out, s)
}

#[test]
fn run_with_the_emulator_closes_the_loop_and_reports_the_device() {
    let (d, out, s) = run_plate("devices", "emulator", &[]);
    let l = &s["loop_stats"];
    assert_eq!(l["device"], "emulator");
    let frames = s["frames"].as_u64().unwrap();
    assert_eq!(l["link"]["readings"].as_u64(), Some(frames));
    // The emulated hand renders forces only: the contact's torques were zeroed and counted.
    assert!(l["link"]["masked_frames"].as_u64().unwrap() > 0);
    assert_eq!(l["link"]["max_masked_force_n"].as_f64(), Some(0.0));
    // trajectory.csv holds where the hand went (closed loop), one row per frame.
    let traj = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let rows = traj
        .lines()
        .filter(|l| {
            !l.starts_with('#')
                && l.chars()
                    .next()
                    .is_some_and(|c| c == '-' || c.is_ascii_digit())
        })
        .count();
    assert_eq!(rows as u64, frames);
    let _ = std::fs::remove_dir_all(&d);

    let o = haptic6d(&["run", "plate", "--device", "phantom", "--out", "x"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        err.trim(),
        "error: --device: unknown device `phantom`; expected one of: replay, emulator, haply, udp"
    );
    // The Haply Inverse3: with nothing listening at the service's address, one line that says
    // so (a build with the `haply` feature) or how to build with it (one without).
    let o = haptic6d(&[
        "run",
        "plate",
        "--device",
        "haply",
        "--haply-url",
        "ws://127.0.0.1:9/",
        "--out",
        "x",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    if cfg!(feature = "haply") {
        assert!(err.contains("Inverse Service"), "{err}");
    } else {
        assert!(err.contains("--features haply"), "{err}");
    }
    assert!(!std::path::Path::new("x").exists());
}

#[test]
fn stability_finds_the_plate_bound_at_1_khz() {
    let o = haptic6d(&[
        "stability",
        "--scenes",
        "plate",
        "--rates",
        "1000",
        "--bisections",
        "2",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let at1 = &s[0]["at_1_n_per_mm"][0];
    assert_eq!(at1["stable"], true);
    assert!(at1["ripple_p99_n"].as_f64().unwrap() <= 0.05);
    let search = &s[0]["searches"][0];
    let lo = search["largest_stable_kt"].as_f64().unwrap();
    let hi = search["smallest_unstable_kt"].as_f64().unwrap();
    assert!((2.0..8.0).contains(&lo) && hi <= 8.0, "{lo} .. {hi}");

    let o = haptic6d(&["stability", "--scenes", "teapot"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown scene `teapot`"));
}

/// `run --device udp` with no device program: the loop runs its duration in real time, every
/// frame released (no pose), and reports the device.
#[test]
fn run_with_a_udp_device_and_no_program_runs_released() {
    let (d, _, s) = run_plate(
        "udp",
        "udp",
        &["--udp-listen", "127.0.0.1:0", "--duration", "0.3"],
    );
    let l = &s["loop_stats"];
    assert_eq!(l["device"], "udp");
    assert_eq!(s["frames"].as_u64(), Some(300));
    assert_eq!(l["link"]["readings"].as_u64(), Some(0));
    assert!(l["link"]["released_frames"].as_u64().unwrap() > 200, "{l}");
    let _ = std::fs::remove_dir_all(&d);
}
