//! `haptic6d serve` on a fresh clone: started away from the source tree, with no npm install
//! anywhere, the page and every module it imports (three.js included) are served.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

mod common;
use common::box_obj;

/// The server process, killed (by its own handle) when the test ends, pass or fail.
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A bare HTTP/1.1 GET on `host` (`ip:port`); returns (status code, body).
fn get(host: &str, path: &str) -> (u16, String) {
    let mut s = TcpStream::connect(host).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).unwrap();
    let text = String::from_utf8_lossy(&buf).to_string();
    let status: u16 = text[9..12].parse().unwrap();
    let body = text
        .split_once("\r\n\r\n")
        .map(|x| x.1.to_string())
        .unwrap_or_default();
    (status, body)
}

/// The module specifiers of the static `import … from '…'` / `export … from '…'` statements.
fn imports(js: &str) -> Vec<String> {
    let mut out = Vec::new();
    for quote in ['\'', '"'] {
        let key = format!("from {quote}");
        let mut rest = js;
        while let Some(i) = rest.find(&key) {
            rest = &rest[i + key.len()..];
            if let Some(end) = rest.find(quote) {
                out.push(rest[..end].to_string());
            }
        }
    }
    out
}

#[test]
fn serve_gives_the_page_and_all_its_modules_without_npm() {
    let dir = std::env::temp_dir().join(format!("haptic6d-serve-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("box.obj"), box_obj(10.0)).unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "[tool]\nmesh = \"box.obj\"\ndepth = 2\nstart = [0, 0, 40, 0, 0, 0]\n\n\
         [[object]]\nmesh = \"box.obj\"\ndepth = 2\n",
    )
    .unwrap();
    // Run from the temporary folder, so nothing of the source tree is at hand.
    let child = Command::new(env!("CARGO_BIN_EXE_haptic6d"))
        .args([
            "serve",
            "scene.toml",
            "--port",
            "0",
            "--no-udp",
            "--duration",
            "60",
        ])
        .current_dir(&dir)
        .env("HAPTIC6D_CACHE", dir.join("cache"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the haptic6d binary runs");
    let mut server = Server(child);
    let mut first = String::new();
    BufReader::new(server.0.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let host = first
        .split("open http://")
        .nth(1)
        .and_then(|r| r.trim().strip_suffix('/'))
        .unwrap_or_else(|| {
            let mut err = String::new();
            let _ = server.0.stderr.take().unwrap().read_to_string(&mut err);
            panic!("no URL in the first line {first:?}; stderr: {err}")
        })
        .to_string();

    let (code, page) = get(&host, "/");
    assert_eq!(code, 200);
    // The import map's entries, e.g. { "imports": { "three": "/vendor/three/three.module.js" } }.
    let map = page
        .split("\"imports\"")
        .nth(1)
        .expect("the page has an import map");
    let map = &map[..map.find('}').unwrap()];
    let resolve = |spec: &str| -> String {
        let key = format!("\"{spec}\"");
        let i = map
            .find(&key)
            .unwrap_or_else(|| panic!("`{spec}` is not in the import map"));
        let v = &map[i + key.len()..];
        let v = &v[v.find('"').unwrap() + 1..];
        v[..v.find('"').unwrap()].to_string()
    };
    // Walk the module graph from the page's script: every module must be served.
    let mut todo = vec!["/app.js".to_string()];
    let mut seen: Vec<String> = Vec::new();
    while let Some(url) = todo.pop() {
        if seen.contains(&url) {
            continue;
        }
        let (code, js) = get(&host, &url);
        assert_eq!(code, 200, "{url}: {js}");
        assert!(!js.trim().is_empty(), "{url} is empty");
        for spec in imports(&js) {
            let next = if let Some(rel) = spec.strip_prefix("./") {
                format!("{}/{rel}", &url[..url.rfind('/').unwrap()])
            } else if spec.starts_with('/') {
                spec
            } else {
                resolve(&spec)
            };
            todo.push(next);
        }
        seen.push(url);
    }
    seen.sort();
    assert_eq!(
        seen,
        [
            "/app.js",
            "/vendor/three/three.core.js",
            "/vendor/three/three.module.js"
        ],
        "the page's module graph"
    );
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The vendored three.js is the version its README names, and the page's npm manifest no
/// longer asks for another copy.
#[test]
fn vendored_three_matches_its_readme() {
    let web = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../viewer/web");
    let core = std::fs::read_to_string(web.join("vendor/three/three.core.js")).unwrap();
    let rev = core
        .split("const REVISION = '")
        .nth(1)
        .and_then(|r| r.split('\'').next())
        .expect("three.core.js names its REVISION");
    let readme = std::fs::read_to_string(web.join("vendor/three/README.md")).unwrap();
    assert!(
        readme.contains(&format!("three@0.{rev}.0")),
        "README does not name three@0.{rev}.0"
    );
    let manifest = std::fs::read_to_string(web.join("package.json")).unwrap();
    assert!(
        !manifest.contains("\"three\""),
        "package.json still installs three"
    );
}
