//! The UDP device bridge protocol, version 2 (the normative text is in docs/VIEWER.md).
//!
//! Every datagram is little-endian and starts with the same 24-byte header:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 4]` | magic `b"H6DB"` |
//! | 4 | `u8` | version, [`VERSION`] = 2 |
//! | 5 | `u8` | kind: 1 [`Kind::Pose`], 2 [`Kind::Wrench`], 3 [`Kind::Bye`], 4 [`Kind::Hello`] |
//! | 6 | `u16` | flags (see [`flags`]) |
//! | 8 | `u32` | `seq`: the sender's sequence number, +1 per datagram, wrapping |
//! | 12 | `u32` | `ack`: in a WRENCH, the `seq` of the newest POSE applied; 0 otherwise |
//! | 16 | `u64` | `time_us`: POSE: the client's clock (µs); WRENCH: echo of that POSE's `time_us` |
//!
//! POSE (72 bytes) carries `q = (x, y, z, gamma, beta, alpha)` as 6 `f64` (mm, rad).
//! WRENCH (128 bytes) carries force (3 `f64`, N), torque (3 `f64`, N·mm), the graphic pose
//! (6 `f64`, mm, rad), the pair count (`u32`) and 4 reserved bytes. BYE and HELLO are the
//! header alone.
//!
//! Version 2 added sessions: a device program opens one with HELLO before its POSEs are
//! applied, and needs a new one after a timeout or BYE (version 1 applied the first POSE from
//! anyone, so a stale datagram arriving after a timeout re-engaged the device).

/// Protocol magic, the first four bytes of every datagram.
pub const MAGIC: [u8; 4] = *b"H6DB";
/// Protocol version carried in byte 4.
pub const VERSION: u8 = 2;
/// Header size (bytes).
pub const HEADER_LEN: usize = 24;
/// POSE datagram size (bytes).
pub const POSE_LEN: usize = HEADER_LEN + 48;
/// WRENCH datagram size (bytes).
pub const WRENCH_LEN: usize = HEADER_LEN + 104;
/// BYE datagram size (bytes).
pub const BYE_LEN: usize = HEADER_LEN;
/// HELLO datagram size (bytes).
pub const HELLO_LEN: usize = HEADER_LEN;
/// Default server-side timeout (ms): no fresh POSE for this long releases the device (zero force).
pub const DEFAULT_TIMEOUT_MS: u64 = 100;

/// Flag bits of the header's `flags` field.
pub mod flags {
    /// WRENCH: the device is released (no live input, e.g. the POSE stream timed out or
    /// another source drives the loop); force and torque are zero.
    pub const RELEASED: u16 = 1 << 0;
    /// WRENCH: the tool is in contact (at least one constraint pair).
    pub const CONTACT: u16 = 1 << 1;
    /// WRENCH: the last POSE was not applied because another client owns the bridge.
    pub const BUSY: u16 = 1 << 2;
    /// WRENCH: the last POSE was not applied because its sender has no session (none opened
    /// yet, or it timed out or said BYE): send HELLO to open one.
    pub const NO_SESSION: u16 = 1 << 3;
    /// WRENCH: the answer to a HELLO that opened a session; POSEs with a `seq` newer than the
    /// HELLO's are applied from now on.
    pub const SESSION: u16 = 1 << 4;
    /// POSE: a probe — do not apply the pose, only answer with the current state (graphic pose,
    /// RELEASED set). Lets a device program learn where the tool is before it engages.
    pub const PROBE: u16 = 1 << 8;
}

/// Datagram kind (header byte 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// Client → server: the device pose.
    Pose = 1,
    /// Server → client: the wrench to render and the graphic pose.
    Wrench = 2,
    /// Client → server: release the device now (zero force), end the session, free the bridge.
    Bye = 3,
    /// Client → server: open a session (take the bridge if it is free); answered with a
    /// WRENCH carrying [`flags::SESSION`] (or [`flags::BUSY`]).
    Hello = 4,
}

/// The header fields common to every datagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Datagram kind.
    pub kind: Kind,
    /// Flag bits ([`flags`]).
    pub flags: u16,
    /// Sender's sequence number.
    pub seq: u32,
    /// Acknowledged POSE sequence number (WRENCH only).
    pub ack: u32,
    /// Client clock (µs) or its echo.
    pub time_us: u64,
}

/// A POSE datagram.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseMsg {
    /// Header.
    pub header: Header,
    /// Device configuration `(x, y, z, gamma, beta, alpha)` (mm, rad).
    pub q: [f64; 6],
}

/// A WRENCH datagram.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WrenchMsg {
    /// Header.
    pub header: Header,
    /// Force to render on the device (N).
    pub force: [f64; 3],
    /// Torque to render on the device (N·mm).
    pub torque: [f64; 3],
    /// Graphic tool configuration (mm, rad).
    pub graphic: [f64; 6],
    /// Active contact pairs.
    pub pairs: u32,
}

/// Any datagram.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message {
    /// Device pose (client → server).
    Pose(PoseMsg),
    /// Wrench (server → client).
    Wrench(WrenchMsg),
    /// Release (client → server).
    Bye(Header),
    /// Open a session (client → server).
    Hello(Header),
}

/// Why a datagram was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// Shorter than its kind requires, or longer.
    #[error("datagram of {got} bytes, expected {expected} for this kind")]
    Length {
        /// Bytes received.
        got: usize,
        /// Bytes the kind requires.
        expected: usize,
    },
    /// The first four bytes are not `H6DB`.
    #[error("bad magic (not a haptic6d bridge datagram)")]
    Magic,
    /// A version this build does not speak.
    #[error("protocol version {0} is not supported (this build speaks version 2)")]
    Version(u8),
    /// An unknown kind byte.
    #[error("unknown datagram kind {0}")]
    Kind(u8),
    /// A NaN or infinite number in the payload.
    #[error("non-finite number in the payload")]
    NotFinite,
}

fn put_header(buf: &mut [u8], h: &Header) {
    buf[0..4].copy_from_slice(&MAGIC);
    buf[4] = VERSION;
    buf[5] = h.kind as u8;
    buf[6..8].copy_from_slice(&h.flags.to_le_bytes());
    buf[8..12].copy_from_slice(&h.seq.to_le_bytes());
    buf[12..16].copy_from_slice(&h.ack.to_le_bytes());
    buf[16..24].copy_from_slice(&h.time_us.to_le_bytes());
}

fn put_f64s(buf: &mut [u8], at: usize, v: &[f64]) -> usize {
    let mut o = at;
    for x in v {
        buf[o..o + 8].copy_from_slice(&x.to_le_bytes());
        o += 8;
    }
    o
}

fn get_f64s<const N: usize>(buf: &[u8], at: usize) -> [f64; N] {
    let mut out = [0.0; N];
    for (i, x) in out.iter_mut().enumerate() {
        let o = at + 8 * i;
        let mut b = [0u8; 8];
        b.copy_from_slice(&buf[o..o + 8]);
        *x = f64::from_le_bytes(b);
    }
    out
}

impl PoseMsg {
    /// Encodes into `buf` (at least [`POSE_LEN`] bytes); returns the datagram slice length.
    pub fn encode(&self, buf: &mut [u8; POSE_LEN]) -> usize {
        put_header(
            buf,
            &Header {
                kind: Kind::Pose,
                ..self.header
            },
        );
        put_f64s(buf, HEADER_LEN, &self.q)
    }
}

impl WrenchMsg {
    /// Encodes into `buf`; returns the datagram length.
    pub fn encode(&self, buf: &mut [u8; WRENCH_LEN]) -> usize {
        put_header(
            buf,
            &Header {
                kind: Kind::Wrench,
                ..self.header
            },
        );
        let mut o = put_f64s(buf, HEADER_LEN, &self.force);
        o = put_f64s(buf, o, &self.torque);
        o = put_f64s(buf, o, &self.graphic);
        buf[o..o + 4].copy_from_slice(&self.pairs.to_le_bytes());
        buf[o + 4..o + 8].copy_from_slice(&[0; 4]);
        o + 8
    }
}

/// Encodes a BYE datagram.
pub fn encode_bye(seq: u32, buf: &mut [u8; BYE_LEN]) -> usize {
    put_header(
        buf,
        &Header {
            kind: Kind::Bye,
            flags: 0,
            seq,
            ack: 0,
            time_us: 0,
        },
    );
    BYE_LEN
}

/// Encodes a HELLO datagram (`time_us`: the client's clock, echoed in the answer).
pub fn encode_hello(seq: u32, time_us: u64, buf: &mut [u8; HELLO_LEN]) -> usize {
    put_header(
        buf,
        &Header {
            kind: Kind::Hello,
            flags: 0,
            seq,
            ack: 0,
            time_us,
        },
    );
    HELLO_LEN
}

/// Decodes one datagram, checking magic, version, kind, exact length and finiteness.
pub fn decode(buf: &[u8]) -> Result<Message, DecodeError> {
    if buf.len() < HEADER_LEN {
        return Err(DecodeError::Length {
            got: buf.len(),
            expected: HEADER_LEN,
        });
    }
    if buf[0..4] != MAGIC {
        return Err(DecodeError::Magic);
    }
    if buf[4] != VERSION {
        return Err(DecodeError::Version(buf[4]));
    }
    let kind = match buf[5] {
        1 => Kind::Pose,
        2 => Kind::Wrench,
        3 => Kind::Bye,
        4 => Kind::Hello,
        k => return Err(DecodeError::Kind(k)),
    };
    let expected = match kind {
        Kind::Pose => POSE_LEN,
        Kind::Wrench => WRENCH_LEN,
        Kind::Bye => BYE_LEN,
        Kind::Hello => HELLO_LEN,
    };
    if buf.len() != expected {
        return Err(DecodeError::Length {
            got: buf.len(),
            expected,
        });
    }
    let u16_at = |o: usize| u16::from_le_bytes([buf[o], buf[o + 1]]);
    let u32_at = |o: usize| u32::from_le_bytes([buf[o], buf[o + 1], buf[o + 2], buf[o + 3]]);
    let mut t = [0u8; 8];
    t.copy_from_slice(&buf[16..24]);
    let header = Header {
        kind,
        flags: u16_at(6),
        seq: u32_at(8),
        ack: u32_at(12),
        time_us: u64::from_le_bytes(t),
    };
    match kind {
        Kind::Pose => {
            let q: [f64; 6] = get_f64s(buf, HEADER_LEN);
            if !q.iter().all(|v| v.is_finite()) {
                return Err(DecodeError::NotFinite);
            }
            Ok(Message::Pose(PoseMsg { header, q }))
        }
        Kind::Wrench => {
            let force: [f64; 3] = get_f64s(buf, HEADER_LEN);
            let torque: [f64; 3] = get_f64s(buf, HEADER_LEN + 24);
            let graphic: [f64; 6] = get_f64s(buf, HEADER_LEN + 48);
            if !force
                .iter()
                .chain(&torque)
                .chain(&graphic)
                .all(|v| v.is_finite())
            {
                return Err(DecodeError::NotFinite);
            }
            Ok(Message::Wrench(WrenchMsg {
                header,
                force,
                torque,
                graphic,
                pairs: u32_at(HEADER_LEN + 96),
            }))
        }
        Kind::Bye => Ok(Message::Bye(header)),
        Kind::Hello => Ok(Message::Hello(header)),
    }
}

/// True when sequence number `a` is newer than `b` under wrap-around (serial number
/// arithmetic: `a` is newer when `a - b`, as a signed 32-bit number, is positive).
#[inline]
pub fn seq_newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(kind: Kind) -> Header {
        Header {
            kind,
            flags: flags::CONTACT,
            seq: 0xdead_beef,
            ack: 7,
            time_us: 1_234_567_890_123,
        }
    }

    #[test]
    fn pose_round_trips_bit_exact() {
        let m = PoseMsg {
            header: header(Kind::Pose),
            q: [1.5, -2.25, 1e-9, 0.1, -3.0, 2.0],
        };
        let mut buf = [0u8; POSE_LEN];
        assert_eq!(m.encode(&mut buf), POSE_LEN);
        assert_eq!(&buf[0..4], b"H6DB");
        assert_eq!(buf[4], 2);
        assert_eq!(buf[5], 1);
        // Little-endian seq at offset 8.
        assert_eq!(&buf[8..12], &[0xef, 0xbe, 0xad, 0xde]);
        assert_eq!(decode(&buf), Ok(Message::Pose(m)));
    }

    #[test]
    fn wrench_round_trips_bit_exact() {
        let m = WrenchMsg {
            header: header(Kind::Wrench),
            force: [0.5, -1.0, 3.25],
            torque: [10.0, -20.0, 30.5],
            graphic: [1.0, 2.0, 3.0, 0.1, 0.2, 0.3],
            pairs: 42,
        };
        let mut buf = [0u8; WRENCH_LEN];
        assert_eq!(m.encode(&mut buf), WRENCH_LEN);
        assert_eq!(decode(&buf), Ok(Message::Wrench(m)));
    }

    #[test]
    fn malformed_datagrams_are_rejected_with_the_reason() {
        let m = PoseMsg {
            header: header(Kind::Pose),
            q: [0.0; 6],
        };
        let mut buf = [0u8; POSE_LEN];
        m.encode(&mut buf);
        assert_eq!(
            decode(&buf[..POSE_LEN - 1]),
            Err(DecodeError::Length {
                got: POSE_LEN - 1,
                expected: POSE_LEN
            })
        );
        assert!(matches!(
            decode(&buf[..10]),
            Err(DecodeError::Length { .. })
        ));
        let mut bad = buf;
        bad[0] = b'X';
        assert_eq!(decode(&bad), Err(DecodeError::Magic));
        let mut bad = buf;
        bad[4] = 1;
        assert_eq!(decode(&bad), Err(DecodeError::Version(1)));
        let mut bad = buf;
        bad[5] = 9;
        assert_eq!(decode(&bad), Err(DecodeError::Kind(9)));
        let mut bad = buf;
        bad[HEADER_LEN + 16..HEADER_LEN + 24].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(decode(&bad), Err(DecodeError::NotFinite));
    }

    #[test]
    fn hello_round_trips_and_has_one_length() {
        let mut buf = [0u8; HELLO_LEN];
        assert_eq!(encode_hello(77, 5_000, &mut buf), HELLO_LEN);
        assert_eq!(buf[5], 4);
        let Ok(Message::Hello(h)) = decode(&buf) else {
            panic!("not a hello: {:?}", decode(&buf))
        };
        assert_eq!((h.kind, h.seq, h.time_us), (Kind::Hello, 77, 5_000));
        let mut long = buf.to_vec();
        long.push(0);
        assert_eq!(
            decode(&long),
            Err(DecodeError::Length {
                got: HELLO_LEN + 1,
                expected: HELLO_LEN
            })
        );
    }

    #[test]
    fn sequence_comparison_survives_wrap_around() {
        assert!(seq_newer(1, 0));
        assert!(!seq_newer(0, 1));
        assert!(!seq_newer(5, 5));
        assert!(seq_newer(0, u32::MAX));
        assert!(seq_newer(3, u32::MAX - 3));
        assert!(!seq_newer(u32::MAX - 3, 3));
    }
}
