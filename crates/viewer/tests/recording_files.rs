//! Recording files never lose what a user has: an existing file is refused unless overwriting
//! was asked for, and even then it keeps its content until the recording ends; the rows go to
//! a temporary file beside it, in whole rows, and only a complete recording takes the name.

mod common;

use std::path::Path;
use std::time::Duration;

use viewer::{HapticLoop, Pacing, ViewerError};

fn partials(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial"))
        .collect()
}

#[test]
fn an_existing_file_is_refused_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("precious.csv");
    std::fs::write(&path, "my data\n").unwrap();
    let haptic = HapticLoop::spawn(common::Floor::new(), &Pacing::default()).unwrap();
    let e = haptic.start_recording(&path, false).unwrap_err();
    assert!(matches!(e, ViewerError::RecordExists { .. }), "{e}");
    assert!(e.to_string().contains("--force"), "{e}");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "my data\n");
    assert!(partials(dir.path()).is_empty());
    // A directory (or any non-regular file) is refused even when overwriting.
    let e = haptic.start_recording(dir.path(), true).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
}

#[test]
fn overwriting_replaces_the_file_only_when_the_recording_ends() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("take.csv");
    std::fs::write(&path, "old take\n").unwrap();
    let haptic = HapticLoop::spawn(common::Floor::new(), &Pacing::default()).unwrap();
    haptic.start_recording(&path, true).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    // While recording, the old file is untouched and the rows go to one temporary file, which
    // always ends at a row boundary.
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "old take\n");
    let tmp = partials(dir.path());
    assert_eq!(tmp.len(), 1, "{tmp:?}");
    let partial = std::fs::read_to_string(dir.path().join(&tmp[0])).unwrap();
    assert!(partial.starts_with("t,x,y,z,gamma,beta,alpha\n") && partial.ends_with('\n'));
    assert!(
        partial.lines().count() > 50,
        "rows are flushed while recording"
    );
    let s = haptic.stop_recording().unwrap();
    assert_eq!(s.path, path);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("t,x,y,z,gamma,beta,alpha\n"));
    assert_eq!(text.lines().count() as u64, s.rows + 1);
    assert!(text
        .lines()
        .skip(1)
        .all(|l| l.split(',').count() == 7 && l.split(',').all(|v| v.parse::<f64>().is_ok())));
    assert!(partials(dir.path()).is_empty());
}

#[test]
fn a_file_that_appears_during_the_recording_is_not_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("late.csv");
    let haptic = HapticLoop::spawn(common::Floor::new(), &Pacing::default()).unwrap();
    haptic.start_recording(&path, false).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    std::fs::write(&path, "someone else's\n").unwrap();
    let e = haptic.stop_recording().unwrap_err();
    let ViewerError::RecordNotMoved { kept, .. } = &e else {
        panic!("{e}")
    };
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "someone else's\n");
    let rows = std::fs::read_to_string(kept).unwrap();
    assert!(rows.starts_with("t,x,y,z,gamma,beta,alpha\n"), "{e}");
    assert!(e.to_string().contains(&kept.display().to_string()));
}
