//! Who may talk to the web server: the `Host` and `Origin` checks that keep other web pages
//! (and DNS-rebinding attacks) from driving the device.
//!
//! - `Host` must name the served address: `127.0.0.1:PORT`, `localhost:PORT`, `[::1]:PORT`, the
//!   bound address itself, or the host of an origin allowed with `--allow-origin`. When the
//!   server is bound to every interface (`0.0.0.0` / `::`), any IP literal with the served port
//!   is accepted too (an IP literal cannot be rebound; a host name can).
//! - `Origin`, when present (browsers always send it on a WebSocket upgrade and on cross-origin
//!   requests), must be the page's own origin (`http://` + the request's accepted `Host`) or one
//!   allowed with `--allow-origin`. Programs that send no `Origin` (device scripts, curl) are
//!   not web pages and pass.

use std::net::{IpAddr, SocketAddr};

use crate::error::ViewerError;

/// The accepted `Host` and `Origin` values of one server.
#[derive(Clone, Debug)]
pub struct AccessPolicy {
    port: u16,
    any_ip: bool,
    hosts: Vec<String>,
    origins: Vec<String>,
}

/// Why a request was refused (answered 403 with this text).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// No `Host` header (HTTP/1.1 requires one).
    #[error("missing Host header")]
    NoHost,
    /// A `Host` that does not name this server (DNS rebinding).
    #[error("Host `{0}` is not this server's address (allow it with --allow-origin)")]
    Host(String),
    /// An `Origin` of another site.
    #[error("Origin `{0}` may not use this server (allow it with --allow-origin)")]
    Origin(String),
}

/// Normalises `http(s)://host[:port]` (no path, query or user info) to lower case without a
/// trailing slash; the error says what is wrong.
pub fn parse_origin(s: &str) -> Result<String, String> {
    let lower = s.trim().to_ascii_lowercase();
    // The scheme first: `http://` alone is an origin without a host, not a bad scheme.
    let scheme = ["http://", "https://"]
        .into_iter()
        .find(|p| lower.starts_with(p))
        .ok_or_else(|| format!("`{s}` must start with http:// or https://"))?;
    let rest = lower[scheme.len()..].trim_end_matches('/');
    let lower = format!("{scheme}{rest}");
    if rest.is_empty() {
        return Err(format!("`{s}` has no host"));
    }
    if rest.contains(['/', '?', '#', '@']) || rest.chars().any(|c| c.is_whitespace()) {
        return Err(format!(
            "`{s}` must be an origin only: scheme://host[:port], no path, query or user"
        ));
    }
    if let Some((_, port)) = split_port(rest) {
        if port.parse::<u16>().is_err() {
            return Err(format!("`{s}` has an invalid port `{port}`"));
        }
    }
    Ok(lower)
}

/// Splits `host:port` (IPv6 in brackets) into host and port; `None` without a port.
fn split_port(hostport: &str) -> Option<(&str, &str)> {
    if let Some(end) = hostport.strip_prefix('[').and_then(|r| r.find(']')) {
        let after = &hostport[end + 2..];
        return after.strip_prefix(':').map(|p| (&hostport[..end + 2], p));
    }
    hostport.rsplit_once(':')
}

fn host_of_ip(ip: IpAddr) -> String {
    match ip {
        IpAddr::V4(v4) => v4.to_string(),
        IpAddr::V6(v6) => format!("[{v6}]"),
    }
}

impl AccessPolicy {
    /// The policy of a server listening on `served`, also accepting the origins in `allowed`
    /// (each `http(s)://host[:port]`; the error names `--allow-origin` and the bad value).
    pub fn new(served: SocketAddr, allowed: &[String]) -> Result<Self, ViewerError> {
        let port = served.port();
        let mut hosts: Vec<String> = ["127.0.0.1", "localhost", "[::1]"]
            .iter()
            .map(|h| format!("{h}:{port}"))
            .collect();
        let ip = served.ip();
        if !ip.is_unspecified() {
            hosts.push(format!("{}:{port}", host_of_ip(ip)));
        }
        let mut origins = Vec::new();
        for a in allowed {
            let o =
                parse_origin(a).map_err(|e| ViewerError::Params(format!("--allow-origin {e}")))?;
            let (scheme_default, hostport) = match o.strip_prefix("https://") {
                Some(h) => (443, h),
                None => (80, &o["http://".len()..]),
            };
            hosts.push(match split_port(hostport) {
                Some(_) => hostport.to_string(),
                None => format!("{hostport}:{scheme_default}"),
            });
            origins.push(o);
        }
        Ok(Self {
            port,
            any_ip: ip.is_unspecified(),
            hosts,
            origins,
        })
    }

    /// Checks one request's `Host` and `Origin` header values.
    pub fn check(&self, host: Option<&str>, origin: Option<&str>) -> Result<(), Refusal> {
        let raw_host = host.ok_or(Refusal::NoHost)?;
        let host = raw_host.trim().to_ascii_lowercase();
        // A Host without a port means the scheme's default (80 for plain HTTP).
        let full = match split_port(&host) {
            Some(_) => host.clone(),
            None => format!("{host}:80"),
        };
        let ip_literal = split_port(&full).is_some_and(|(h, p)| {
            p.parse::<u16>() == Ok(self.port)
                && h.trim_start_matches('[')
                    .trim_end_matches(']')
                    .parse::<IpAddr>()
                    .is_ok()
        });
        if !(self.hosts.contains(&full) || (self.any_ip && ip_literal)) {
            return Err(Refusal::Host(raw_host.to_string()));
        }
        if let Some(o) = origin {
            let o_norm = o.trim().trim_end_matches('/').to_ascii_lowercase();
            let same = o_norm == format!("http://{host}") || o_norm == format!("http://{full}");
            if !(same || self.origins.contains(&o_norm)) {
                return Err(Refusal::Origin(o.to_string()));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn local(port: u16) -> AccessPolicy {
        AccessPolicy::new(SocketAddr::from(([127, 0, 0, 1], port)), &[]).unwrap()
    }

    #[test]
    fn the_served_address_passes_with_its_own_origin() {
        let p = local(8080);
        for h in [
            "127.0.0.1:8080",
            "localhost:8080",
            "[::1]:8080",
            "LOCALHOST:8080",
        ] {
            assert_eq!(p.check(Some(h), None), Ok(()), "{h}");
            let o = format!("http://{}", h.to_ascii_lowercase());
            assert_eq!(p.check(Some(h), Some(&o)), Ok(()), "{h} {o}");
        }
    }

    #[test]
    fn foreign_hosts_and_origins_are_refused() {
        let p = local(8080);
        assert_eq!(
            p.check(Some("evil.example:8080"), None),
            Err(Refusal::Host("evil.example:8080".into()))
        );
        assert!(p.check(Some("127.0.0.1:9999"), None).is_err());
        assert!(p.check(Some("127.0.0.1"), None).is_err());
        assert!(p.check(Some("10.0.0.7:8080"), None).is_err());
        assert_eq!(p.check(None, None), Err(Refusal::NoHost));
        assert_eq!(
            p.check(Some("127.0.0.1:8080"), Some("http://evil.example")),
            Err(Refusal::Origin("http://evil.example".into()))
        );
        // Another page on the same machine, other port: a different origin.
        assert!(p
            .check(Some("127.0.0.1:8080"), Some("http://127.0.0.1:3000"))
            .is_err());
        // The page of localhost talking to 127.0.0.1 is cross-origin as well.
        assert!(p
            .check(Some("127.0.0.1:8080"), Some("http://localhost:8080"))
            .is_err());
        assert!(p.check(Some("127.0.0.1:8080"), Some("null")).is_err());
    }

    #[test]
    fn allowed_origins_add_their_host() {
        let allowed = vec!["https://lab.example/".to_string(), "http://box:9000".into()];
        let p = AccessPolicy::new(SocketAddr::from(([127, 0, 0, 1], 8080)), &allowed).unwrap();
        assert_eq!(
            p.check(Some("lab.example"), Some("https://lab.example")),
            Err(Refusal::Host("lab.example".into())),
            "https's default port is 443, a bare Host means 80"
        );
        assert_eq!(
            p.check(Some("lab.example:443"), Some("https://lab.example")),
            Ok(())
        );
        assert_eq!(p.check(Some("box:9000"), Some("http://box:9000")), Ok(()));
        assert_eq!(
            p.check(Some("127.0.0.1:8080"), Some("http://box:9000")),
            Ok(())
        );
        assert!(p.check(Some("box:9001"), None).is_err());
    }

    #[test]
    fn every_interface_accepts_ip_literals_but_not_names() {
        let p = AccessPolicy::new(SocketAddr::from(([0, 0, 0, 0], 8080)), &[]).unwrap();
        assert_eq!(
            p.check(Some("192.168.1.5:8080"), Some("http://192.168.1.5:8080")),
            Ok(())
        );
        assert!(p.check(Some("192.168.1.5:8081"), None).is_err());
        assert!(p.check(Some("rebind.example:8080"), None).is_err());
        assert!(p
            .check(Some("192.168.1.5:8080"), Some("http://10.0.0.9:8080"))
            .is_err());
    }

    #[test]
    fn bad_allowed_origins_name_the_flag() {
        for bad in [
            "lab.example",
            "ftp://x",
            "http://x/path",
            "http://x:99999",
            "http://",
        ] {
            let e = AccessPolicy::new(SocketAddr::from(([127, 0, 0, 1], 1)), &[bad.into()])
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("--allow-origin") && !e.contains('\n'),
                "{bad}: {e}"
            );
        }
    }
}
