//! Reading an input file with a size limit: a device node (`/dev/zero`), a directory or a file
//! larger than the limit is refused before it is read, instead of being read until memory
//! runs out.

use std::io::{Read, Write};
use std::path::Path;

/// Largest mesh file read, bytes (1 GiB: a 20 M-triangle binary STL).
pub const MAX_MESH_BYTES: u64 = 1 << 30;

/// Reads the whole of `path`, refusing directories, character and block devices (which never
/// end, or are not files), and anything larger than `max_bytes`. Pipes are read up to the
/// limit. Errors are one line (`io::ErrorKind::InvalidInput` for the refusals).
pub fn read_input(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    let refuse = |msg: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, msg);
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    let ft = meta.file_type();
    if ft.is_dir() {
        return Err(refuse("is a directory, not a file".into()));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_char_device() || ft.is_block_device() || ft.is_socket() {
            return Err(refuse(
                "is a device or socket, not a regular file; give a file".into(),
            ));
        }
    }
    if ft.is_file() && meta.len() > max_bytes {
        return Err(refuse(format!(
            "is {} bytes, more than the limit of {max_bytes} bytes",
            meta.len()
        )));
    }
    let mut bytes = Vec::new();
    // One byte past the limit tells a pipe (or a file that grew) that is too long.
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(refuse(format!(
            "holds more than the limit of {max_bytes} bytes"
        )));
    }
    Ok(bytes)
}

/// The rule for every file the tools write: the path must be new, or an existing regular
/// file (which is replaced). Anything else that exists there — a symbolic link (even to a
/// regular file: renaming over it would replace the link, and writing through it would
/// write somewhere the user did not name), a folder, a device, a fifo or a socket — is
/// refused with `io::ErrorKind::InvalidInput` and a one-line reason, and nothing is written.
pub fn check_output_file(path: &Path) -> std::io::Result<()> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e),
    };
    let ft = meta.file_type();
    let what = if ft.is_file() {
        return Ok(());
    } else if ft.is_symlink() {
        "a symbolic link"
    } else if ft.is_dir() {
        "a folder"
    } else {
        "a device, fifo or socket"
    };
    Err(std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!("exists and is {what}, not a regular file; outputs replace only regular files: give a new path or a regular file"),
    ))
}

/// Writes `bytes` to `path` atomically: a fresh temporary file beside `path` (never an existing
/// one) is written, synced and renamed over `path`, so a reader never sees a half-written file
/// and a failure leaves an existing file as it was (the temporary file is removed). A `path`
/// that exists and is not a regular file is refused ([`check_output_file`]).
///
/// The parent folder must exist.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    check_output_file(path)?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name"))?
        .to_string_lossy()
        .into_owned();
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let mut attempt = 0u32;
    let (tmp, mut file) = loop {
        let tmp = dir.join(format!(
            ".{name}.tmp-{}-{stamp}-{attempt}",
            std::process::id()
        ));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
        {
            Ok(f) => break (tmp, f),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 100 => {
                attempt += 1;
            }
            Err(e) => return Err(e),
        }
    };
    let result = file
        .write_all(bytes)
        .and_then(|()| file.sync_all())
        .and_then(|()| {
            drop(file);
            std::fs::rename(&tmp, path)
        });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn links_folders_and_devices_are_never_written_over() {
        let dir = std::env::temp_dir().join(format!("mesh-output-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("target.txt");
        std::fs::write(&target, "mine").unwrap();
        let link = dir.join("link.sph");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let e = write_atomic(&link, b"new").unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "mine");
        let e = write_atomic(&dir, b"new").unwrap_err();
        assert!(e.to_string().contains("a folder"), "{e}");
        let e = check_output_file(Path::new("/dev/null")).unwrap_err();
        assert!(e.to_string().contains("device"), "{e}");
        // A regular file is replaced; a new path is created.
        write_atomic(&target, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        write_atomic(&dir.join("fresh.txt"), b"x").unwrap();
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            3,
            "a temporary file was left"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn device_directory_and_oversized_files_are_refused() {
        #[cfg(unix)]
        {
            let e = read_input(Path::new("/dev/zero"), 1 << 20).unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        let dir = std::env::temp_dir();
        let e = read_input(&dir, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("directory"), "{e}");
        let p = dir.join(format!("mesh-input-test-{}", std::process::id()));
        std::fs::write(&p, [7u8; 100]).unwrap();
        let e = read_input(&p, 99).unwrap_err();
        assert!(e.to_string().contains("limit of 99 bytes"), "{e}");
        assert_eq!(read_input(&p, 100).unwrap().len(), 100);
        std::fs::remove_file(&p).unwrap();
    }
}
