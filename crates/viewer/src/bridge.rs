//! The UDP device bridge: a server thread that takes POSE datagrams from one device program,
//! drives the haptic loop with them and answers each with a WRENCH; and [`BridgeClient`], the
//! device program's side. The protocol is in [`crate::protocol`] and docs/VIEWER.md.
//!
//! Safety rules: a device whose POSE stream stops for longer than the timeout is released —
//! the haptic thread holds it at the graphic pose, so force and torque go to zero — and the
//! client, for its part, renders zero force when no WRENCH arrived within its own timeout.
//! POSEs drive the loop only inside a session that the client opened with HELLO; a timeout or
//! BYE ends the session, so a stale or delayed POSE can never re-engage the device: the client
//! must say HELLO again, and the force then ramps up from zero (the engine's soft
//! start on every engagement, see [`crate::SceneSim`]).

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use collide::Pose;

use crate::error::ViewerError;
use crate::hub::{InputHub, InputSource, StateHub};
use crate::protocol::{
    decode, encode_bye, encode_hello, flags, seq_newer, Header, Kind, Message, PoseMsg, WrenchMsg,
    BYE_LEN, HELLO_LEN, POSE_LEN, WRENCH_LEN,
};

/// Bridge settings.
#[derive(Clone, Debug)]
pub struct BridgeParams {
    /// Address to bind (e.g. `127.0.0.1:8081`; port 0 picks a free one).
    pub addr: SocketAddr,
    /// A device whose POSE stream is silent this long is released (zero force) and its
    /// session ends; [`BridgeParams::MIN_TIMEOUT`] ..= [`BridgeParams::MAX_TIMEOUT`].
    pub timeout: Duration,
}

impl BridgeParams {
    /// Shortest accepted timeout (10 ms: ten haptic frames at 1 kHz).
    pub const MIN_TIMEOUT: Duration = Duration::from_millis(10);
    /// Longest accepted timeout (10 s): a silent device must not hold force longer.
    pub const MAX_TIMEOUT: Duration = Duration::from_secs(10);

    /// Checks the settings; the error names the CLI flag and the accepted range.
    pub fn validate(&self) -> Result<(), ViewerError> {
        if self.timeout < Self::MIN_TIMEOUT || self.timeout > Self::MAX_TIMEOUT {
            return Err(ViewerError::Params(format!(
                "--udp-timeout-ms must be between {} and {} ms, got {} ms",
                Self::MIN_TIMEOUT.as_millis(),
                Self::MAX_TIMEOUT.as_millis(),
                self.timeout.as_millis()
            )));
        }
        Ok(())
    }
}

/// Counters of what the bridge did, readable while it runs.
#[derive(Debug, Default)]
pub struct BridgeStats {
    /// POSE datagrams applied.
    pub accepted: AtomicU64,
    /// POSE datagrams dropped as duplicate or out of order (sequence not newer).
    pub stale: AtomicU64,
    /// Datagrams that failed to decode.
    pub malformed: AtomicU64,
    /// POSE and HELLO datagrams refused because another client owns the bridge.
    pub busy: AtomicU64,
    /// POSE datagrams not applied because their sender had no session (never opened, timed
    /// out, or ended by BYE).
    pub no_session: AtomicU64,
    /// Sessions opened (HELLOs accepted).
    pub sessions: AtomicU64,
    /// Times a client timed out.
    pub timeouts: AtomicU64,
}

/// A running bridge server thread.
pub struct UdpBridge {
    local: SocketAddr,
    stop: Arc<AtomicBool>,
    stats: Arc<BridgeStats>,
    thread: Option<JoinHandle<()>>,
}

impl UdpBridge {
    /// Binds `params.addr` and starts the bridge thread (`haptic6d-udp`), feeding `input` and
    /// answering from `state`. Fails on invalid parameters ([`BridgeParams::validate`]) or when
    /// the address cannot be bound.
    pub fn spawn(
        params: &BridgeParams,
        input: Arc<InputHub>,
        state: Arc<StateHub>,
    ) -> Result<Self, ViewerError> {
        params.validate()?;
        let bind_err = |source| ViewerError::Bind {
            what: "UDP bridge",
            addr: params.addr.to_string(),
            source,
        };
        let socket = UdpSocket::bind(params.addr).map_err(bind_err)?;
        socket
            .set_read_timeout(Some(Duration::from_millis(10)))
            .map_err(bind_err)?;
        let local = socket.local_addr().map_err(bind_err)?;
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(BridgeStats::default());
        let server = Server {
            endpoint: UdpEndpoint::new(
                socket,
                params.timeout,
                stats.clone(),
                HubTarget { input, state },
            ),
            stop: stop.clone(),
        };
        let thread = std::thread::Builder::new()
            .name("haptic6d-udp".into())
            .spawn(move || server.run())
            .map_err(ViewerError::Thread)?;
        Ok(Self {
            local,
            stop,
            stats,
            thread: Some(thread),
        })
    }

    /// The bound address (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.local
    }

    /// The bridge's counters.
    pub fn stats(&self) -> &BridgeStats {
        &self.stats
    }

    /// Stops the bridge thread.
    pub fn shutdown(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for UdpBridge {
    fn drop(&mut self) {
        self.halt();
    }
}

struct Owner {
    addr: SocketAddr,
    last_seq: u32,
    last_rx: Instant,
}

/// What a UDP session drives: the viewer's input hub ([`UdpBridge`]) or a device's reading slot
/// ([`crate::UdpDevice`]).
pub(crate) trait SessionTarget {
    /// A pose (mm, rad) from the session's client at `now`, valid until `now + timeout`; true
    /// when it was applied.
    fn drive(&mut self, pose: Pose, now: Instant, timeout: Duration) -> bool;
    /// The session ended (BYE, a new HELLO, a timeout, the end of the server).
    fn release(&mut self);
    /// The reply's content: whether the wrench is this client's, the wrench (N, N·mm), the
    /// graphic pose and the pair count.
    fn answer(&self, applied: bool) -> Answer;
}

/// What a WRENCH reply carries (see [`SessionTarget::answer`]).
pub(crate) struct Answer {
    pub ours: bool,
    pub force: [f64; 3],
    pub torque: [f64; 3],
    pub graphic: [f64; 6],
    pub pairs: u32,
}

/// The server side of the UDP protocol on one socket: at most one client session at a time
/// (HELLO opens it, POSE drives, BYE or a timeout ends it), every POSE and HELLO answered
/// with a WRENCH. Shared by the viewer's bridge thread and the [`crate::UdpDevice`].
pub(crate) struct UdpEndpoint<T: SessionTarget> {
    pub socket: UdpSocket,
    pub timeout: Duration,
    pub stats: Arc<BridgeStats>,
    pub target: T,
    owner: Option<Owner>,
    seq: u32,
}

impl<T: SessionTarget> UdpEndpoint<T> {
    pub fn new(socket: UdpSocket, timeout: Duration, stats: Arc<BridgeStats>, target: T) -> Self {
        Self {
            socket,
            timeout,
            stats,
            target,
            owner: None,
            seq: 0,
        }
    }

    /// Ends a session whose client has been silent longer than the timeout.
    pub fn check_timeout(&mut self, now: Instant) {
        if let Some(o) = &self.owner {
            if now.duration_since(o.last_rx) > self.timeout {
                // The loop already released on the command's expiry; end the session, so
                // that only a fresh HELLO can drive the device again.
                self.target.release();
                self.owner = None;
                self.stats.timeouts.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// Receives one datagram if there is one (within the socket's read timeout) and handles
    /// it; false when there was none.
    pub fn receive_one(&mut self, buf: &mut [u8]) -> bool {
        let (n, from) = match self.socket.recv_from(buf) {
            Ok(x) => x,
            // Nothing there (WouldBlock, TimedOut), or e.g. ICMP port unreachable from a
            // client that went away: keep serving.
            Err(_) => return false,
        };
        match decode(&buf[..n]) {
            Ok(Message::Pose(p)) => self.on_pose(p, from),
            Ok(Message::Hello(h)) => self.on_hello(h, from),
            Ok(Message::Bye(_)) => {
                if self.owner.as_ref().is_some_and(|o| o.addr == from) {
                    self.target.release();
                    self.owner = None;
                }
            }
            Ok(Message::Wrench(_)) | Err(_) => {
                self.stats.malformed.fetch_add(1, Ordering::Relaxed);
            }
        }
        true
    }

    /// Ends any session (the server stops).
    pub fn end(&mut self) {
        if self.owner.take().is_some() {
            self.target.release();
        }
    }

    /// HELLO: open a session for `from` if the bridge is free (or `from` already owns it: a
    /// new session then replaces the old one, releasing the device first).
    fn on_hello(&mut self, h: Header, from: SocketAddr) {
        if self.owner.as_ref().is_some_and(|o| o.addr != from) {
            self.stats.busy.fetch_add(1, Ordering::Relaxed);
            self.reply(&h, from, flags::BUSY | flags::RELEASED, false);
            return;
        }
        if self.owner.is_some() {
            self.target.release();
        }
        self.owner = Some(Owner {
            addr: from,
            last_seq: h.seq,
            last_rx: Instant::now(),
        });
        self.stats.sessions.fetch_add(1, Ordering::Relaxed);
        self.reply(&h, from, flags::SESSION | flags::RELEASED, false);
    }

    fn on_pose(&mut self, p: PoseMsg, from: SocketAddr) {
        let now = Instant::now();
        if p.header.flags & flags::PROBE != 0 {
            self.reply(&p.header, from, flags::RELEASED, false);
            return;
        }
        match &mut self.owner {
            Some(o) if o.addr != from => {
                self.stats.busy.fetch_add(1, Ordering::Relaxed);
                self.reply(&p.header, from, flags::BUSY | flags::RELEASED, false);
                return;
            }
            Some(o) => {
                if !seq_newer(p.header.seq, o.last_seq) {
                    self.stats.stale.fetch_add(1, Ordering::Relaxed);
                    return;
                }
                o.last_seq = p.header.seq;
                o.last_rx = now;
            }
            None => {
                // No session (never opened, timed out, or ended): never applied, whatever its
                // sequence number; the client must open a new session with HELLO.
                self.stats.no_session.fetch_add(1, Ordering::Relaxed);
                self.reply(&p.header, from, flags::NO_SESSION | flags::RELEASED, false);
                return;
            }
        }
        let applied = self.target.drive(Pose::from_array(p.q), now, self.timeout);
        if applied {
            self.stats.accepted.fetch_add(1, Ordering::Relaxed);
        }
        self.reply(&p.header, from, 0, applied);
    }

    /// Answers the datagram with header `req` (a POSE or HELLO) with a WRENCH.
    fn reply(&mut self, req: &Header, to: SocketAddr, extra: u16, applied: bool) {
        self.seq = self.seq.wrapping_add(1);
        let a = self.target.answer(applied);
        let mut fl = extra;
        if !a.ours {
            fl |= flags::RELEASED;
        }
        if a.pairs > 0 {
            fl |= flags::CONTACT;
        }
        let msg = WrenchMsg {
            header: Header {
                kind: Kind::Wrench,
                flags: fl,
                seq: self.seq,
                ack: req.seq,
                time_us: req.time_us,
            },
            force: if a.ours { a.force } else { [0.0; 3] },
            torque: if a.ours { a.torque } else { [0.0; 3] },
            graphic: a.graphic,
            pairs: a.pairs,
        };
        let mut out = [0u8; WRENCH_LEN];
        let n = msg.encode(&mut out);
        // A lost reply is covered by the client's own timeout.
        let _ = self.socket.send_to(&out[..n], to);
    }
}

/// The viewer's haptic loop as a session target: poses go to the input hub (source UDP), the
/// replies carry the wrench the haptic thread published.
struct HubTarget {
    input: Arc<InputHub>,
    state: Arc<StateHub>,
}

impl SessionTarget for HubTarget {
    fn drive(&mut self, pose: Pose, now: Instant, timeout: Duration) -> bool {
        self.input
            .submit(InputSource::Udp, pose, Some(now + timeout))
            .is_ok()
    }

    fn release(&mut self) {
        self.input.release(InputSource::Udp);
    }

    fn answer(&self, applied: bool) -> Answer {
        self.state.with_latest(|s| Answer {
            ours: applied && !s.released && s.source == InputSource::Udp as u8,
            force: s.force,
            torque: s.torque,
            graphic: s.graphic,
            pairs: s.pairs,
        })
    }
}

struct Server {
    endpoint: UdpEndpoint<HubTarget>,
    stop: Arc<AtomicBool>,
}

impl Server {
    fn run(mut self) {
        let mut buf = [0u8; 512];
        while !self.stop.load(Ordering::Acquire) {
            self.endpoint.check_timeout(Instant::now());
            self.endpoint.receive_one(&mut buf);
        }
        self.endpoint.end();
    }
}

/// The device program's end of the bridge: sends POSEs, keeps the newest WRENCH, and says
/// which wrench to render (zero when the server has gone quiet).
pub struct BridgeClient {
    socket: UdpSocket,
    server: SocketAddr,
    seq: u32,
    timeout: Duration,
    epoch: Instant,
    last: Option<(Instant, WrenchMsg)>,
    hello_seq: Option<u32>,
    session: bool,
}

impl BridgeClient {
    /// A client for the bridge at `server`, bound to an ephemeral port on the matching
    /// interface, non-blocking. `timeout`: with no WRENCH for this long, [`Self::wrench`]
    /// returns zero.
    pub fn connect(server: SocketAddr, timeout: Duration) -> io::Result<Self> {
        let local: SocketAddr = if server.ip().is_loopback() {
            if server.is_ipv4() {
                "127.0.0.1:0"
            } else {
                "[::1]:0"
            }
        } else if server.is_ipv4() {
            "0.0.0.0:0"
        } else {
            "[::]:0"
        }
        .parse()
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        let socket = UdpSocket::bind(local)?;
        socket.set_nonblocking(true)?;
        Ok(Self {
            socket,
            server,
            seq: 0,
            timeout,
            epoch: Instant::now(),
            last: None,
            hello_seq: None,
            session: false,
        })
    }

    /// Sends a HELLO asking for a session; returns its sequence number. The answer arrives
    /// through [`Self::poll`]; [`Self::has_session`] then says whether it was granted.
    pub fn hello(&mut self) -> io::Result<u32> {
        self.seq = self.seq.wrapping_add(1);
        let mut buf = [0u8; HELLO_LEN];
        let n = encode_hello(self.seq, self.epoch.elapsed().as_micros() as u64, &mut buf);
        self.socket.send_to(&buf[..n], self.server)?;
        self.hello_seq = Some(self.seq);
        self.session = false;
        Ok(self.seq)
    }

    /// Sends a HELLO and waits up to `wait` for the answer (polling every millisecond);
    /// returns whether a session was granted (false: the bridge is busy or did not answer).
    pub fn open_session(&mut self, wait: Duration) -> io::Result<bool> {
        let seq = self.hello()?;
        let end = Instant::now() + wait;
        loop {
            self.poll()?;
            if self.session {
                return Ok(true);
            }
            if let Some((_, w)) = &self.last {
                if w.header.ack == seq && w.header.flags & flags::BUSY != 0 {
                    return Ok(false);
                }
            }
            if Instant::now() >= end {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// True while this client holds a session: its HELLO was answered with `SESSION` and no
    /// answer since said `NO_SESSION`.
    pub fn has_session(&self) -> bool {
        self.session
    }

    /// Sends the device pose `q` (mm, rad); returns its sequence number. Applied only inside
    /// a session ([`Self::open_session`]); otherwise answered with `NO_SESSION`.
    pub fn send_pose(&mut self, q: [f64; 6]) -> io::Result<u32> {
        self.send(q, 0)
    }

    /// Asks for the current state without driving the tool (a PROBE); the answer arrives
    /// through [`Self::poll`] as a WRENCH with `RELEASED` set and the graphic pose.
    pub fn probe(&mut self) -> io::Result<u32> {
        self.send([0.0; 6], flags::PROBE)
    }

    fn send(&mut self, q: [f64; 6], fl: u16) -> io::Result<u32> {
        self.seq = self.seq.wrapping_add(1);
        let msg = PoseMsg {
            header: Header {
                kind: Kind::Pose,
                flags: fl,
                seq: self.seq,
                ack: 0,
                time_us: self.epoch.elapsed().as_micros() as u64,
            },
            q,
        };
        let mut buf = [0u8; POSE_LEN];
        let n = msg.encode(&mut buf);
        self.socket.send_to(&buf[..n], self.server)?;
        Ok(self.seq)
    }

    /// Reads every WRENCH waiting on the socket and keeps the newest (by `ack`); returns it if
    /// one arrived now.
    pub fn poll(&mut self) -> io::Result<Option<WrenchMsg>> {
        let mut buf = [0u8; 512];
        let mut got = None;
        loop {
            match self.socket.recv_from(&mut buf) {
                Ok((n, from)) => {
                    if from != self.server {
                        continue;
                    }
                    if let Ok(Message::Wrench(w)) = decode(&buf[..n]) {
                        let newer = self
                            .last
                            .as_ref()
                            .is_none_or(|(_, l)| !seq_newer(l.header.ack, w.header.ack));
                        if newer {
                            if w.header.flags & flags::SESSION != 0
                                && self.hello_seq == Some(w.header.ack)
                            {
                                self.session = true;
                            }
                            if w.header.flags & flags::NO_SESSION != 0 {
                                self.session = false;
                            }
                            self.last = Some((Instant::now(), w));
                            got = Some(w);
                        }
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(got),
                // ICMP errors (server not listening) surface here; treat as "nothing yet".
                Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => return Ok(got),
                Err(e) => return Err(e),
            }
        }
    }

    /// The newest WRENCH received, with its arrival time.
    pub fn last(&self) -> Option<&(Instant, WrenchMsg)> {
        self.last.as_ref()
    }

    /// Round-trip time of the newest WRENCH (its echoed `time_us` against this client's clock).
    pub fn round_trip(&self) -> Option<Duration> {
        let (at, w) = self.last.as_ref()?;
        let sent = self.epoch + Duration::from_micros(w.header.time_us);
        at.checked_duration_since(sent)
    }

    /// The force (N) and torque (N·mm) to render at `now`: the newest WRENCH's, or zero when
    /// none arrived within the timeout or the server says the device is released.
    pub fn wrench(&self, now: Instant) -> ([f64; 3], [f64; 3]) {
        match &self.last {
            Some((at, w))
                if now.duration_since(*at) <= self.timeout
                    && w.header.flags & flags::RELEASED == 0 =>
            {
                (w.force, w.torque)
            }
            _ => ([0.0; 3], [0.0; 3]),
        }
    }

    /// Tells the server to release the device now and end the session.
    pub fn bye(&mut self) -> io::Result<()> {
        self.session = false;
        self.seq = self.seq.wrapping_add(1);
        let mut buf = [0u8; BYE_LEN];
        let n = encode_bye(self.seq, &mut buf);
        self.socket.send_to(&buf[..n], self.server)?;
        Ok(())
    }
}
