//! The haptic loop: reads the device, steps the [`Engine`] (god-object step and safety layer)
//! and sends the wrench, once per frame, on a named thread.
//!
//! Two pacing modes:
//! - **real-time** (`LoopParams::realtime`): frame `i` starts at `start + i / rate_hz`; the
//!   thread naps after each frame (and sleeps until `spin_us` before the deadline, when that
//!   is later), then hands the wait to the engine's background work and spins, yielding to
//!   other threads ([`Pacer`], shared with the viewer; sleep alone has ~50–100 µs of jitter on a loaded
//!   Linux box). A frame that ends after the next deadline is an *overrun*;
//!   when the loop falls more than a whole period behind, the schedule is re-based on the
//!   current time (no burst of catch-up frames).
//! - **as fast as possible** (default for `haptic6d run`): no waiting; every frame's timings
//!   are still measured. At a real-time priority the loop rests between two frames once in
//!   a while ([`UNPACED_RUN`]), so that the kernel's real-time limit never stops a frame.
//!
//! Per-frame records are written into storage reserved before the loop starts: the loop itself
//! does not allocate.

use std::time::{Duration, Instant};

use serde::Serialize;

use engine::{Counters, Engine, Frame};

use crate::device::{Device, DeviceLink, DeviceSettings, LinkRead, LinkStats};
use crate::stats::Summary;
use crate::SceneError;
use engine::safety::SafetyEvents;

/// The wall-clock pacing of a haptic loop, shared by `haptic6d run --realtime`
/// ([`LoopParams::pacing`]) and the viewer's loop (`haptic6d serve`).
#[derive(Clone, Debug, PartialEq)]
pub struct Pacing {
    /// Frames per second, Hz ([`engine::config::RATE_HZ`]; 1000 by default).
    pub rate_hz: f64,
    /// How long before a deadline to stop sleeping and start spinning, µs
    /// ([`engine::config::SPIN_US`]; [`DEFAULT_SPIN_US`] by default: after a nap of
    /// [`NAP_US`], the whole wait): trades CPU for timing precision and for the time the
    /// engine's background work gets before each frame.
    pub spin_us: f64,
    /// Ask for a real-time scheduling priority (`SCHED_FIFO`, 1 to 99) for the haptic thread
    /// (best effort: needs the privilege; reported in [`LoopStats`]). `None` (the default)
    /// keeps the normal priority.
    pub rt_priority: Option<i32>,
}

impl Default for Pacing {
    fn default() -> Self {
        Self {
            rate_hz: 1000.0,
            spin_us: DEFAULT_SPIN_US,
            rt_priority: None,
        }
    }
}

/// Accepted `SCHED_FIFO` priorities (Linux's range).
pub const RT_PRIORITY: engine::config::IntRange = engine::config::IntRange {
    key: "--rt-priority",
    lo: 1,
    hi: 99,
    unit: "",
};

impl Pacing {
    /// Checks `rate_hz`, `spin_us` and `rt_priority` against their ranges; the first bad one
    /// is named.
    pub fn validate(&self) -> Result<(), engine::config::SettingError> {
        engine::config::RATE_HZ.check(self.rate_hz)?;
        engine::config::SPIN_US.check(self.spin_us)?;
        match self.rt_priority {
            // A negative priority gets the same message as any other out of range.
            Some(p) => RT_PRIORITY
                .check(u64::try_from(p).unwrap_or(0))
                .map_err(|mut e| {
                    e.value = p.to_string();
                    e
                }),
            None => Ok(()),
        }
    }

    /// The frame period at [`Pacing::effective_rate_hz`] (a bad rate cannot panic in
    /// `Duration`).
    pub fn period(&self) -> Duration {
        Duration::from_secs_f64(1.0 / self.effective_rate_hz())
    }

    /// `rate_hz`, or 1000 Hz when it is outside its range (a validated pacing never is).
    pub fn effective_rate_hz(&self) -> f64 {
        if engine::config::RATE_HZ.contains(self.rate_hz) {
            self.rate_hz
        } else {
            1000.0
        }
    }

    /// The spin before each deadline; none when `spin_us` is outside its range.
    pub fn spin(&self) -> Duration {
        let spin_us = if engine::config::SPIN_US.contains(self.spin_us) {
            self.spin_us
        } else {
            0.0
        };
        Duration::from_secs_f64(spin_us * 1e-6)
    }
}

/// Settings of [`run_loop`].
#[derive(Clone, Debug, PartialEq)]
pub struct LoopParams {
    /// Rate, spin and priority. The rate is also the device clock when not `realtime`.
    pub pacing: Pacing,
    /// Pace frames on the wall clock (else run as fast as possible).
    pub realtime: bool,
    /// Most frames to run (storage is reserved for this many, or for the device's length).
    pub max_frames: usize,
    /// The device's calibration and timeout.
    pub device: DeviceSettings,
}

impl Default for LoopParams {
    fn default() -> Self {
        Self {
            pacing: Pacing::default(),
            realtime: false,
            max_frames: 10_000_000,
            device: DeviceSettings::default(),
        }
    }
}

impl LoopParams {
    /// Checks the pacing and `max_frames` against their ranges; the first bad one is named.
    pub fn validate(&self) -> Result<(), engine::config::SettingError> {
        self.pacing.validate()?;
        self.device.validate()?;
        engine::config::MAX_FRAMES.check(self.max_frames as u64)
    }
}

/// One frame as recorded by the loop.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameRecord {
    /// Device time of the frame (s): the trajectory's `t` on replay.
    pub t: f64,
    /// Wall time since the loop started, s.
    pub t_wall: f64,
    /// The engine's frame (its `t` is the safety layer's clock, see [`run_frames`]).
    pub frame: Frame,
    /// Time since the previous frame started, µs (0 for the first frame).
    pub period_us: f64,
    /// The frame finished after the next frame's deadline.
    pub overrun: bool,
    /// What the device link did ([`crate::device::link_flags`]: held, released, resumed,
    /// masked axes).
    pub link: u8,
}

/// Statistics of a loop run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LoopStats {
    /// Frames run.
    pub frames: usize,
    /// Pacing mode.
    pub realtime: bool,
    /// Nominal rate, Hz.
    pub rate_hz: f64,
    /// The haptic thread ran with a real-time scheduling priority.
    pub rt_priority: bool,
    /// Frames that ended after the next deadline (real-time mode only).
    pub overruns: u64,
    /// `|period - 1/rate|` over frames 1.., µs (real-time mode only).
    pub period_error_us: Summary,
    /// Frame periods, µs.
    pub period_us: Summary,
    /// Safety events.
    pub safety: SafetyEvents,
    /// Frames that kept the last safe pose (step failed).
    pub kept_last_safe: u64,
    /// Frames whose pair list overflowed the reserved storage.
    pub pair_overflows: u64,
    /// Frames whose QP stopped inexact.
    pub inexact: u64,
    /// Frames that ended short of the constrained optimum (passes or budget ran out; the pose
    /// is safe, the tool lags the hand).
    pub lagging: u64,
    /// Frames in which friction held the tool (stick) and in which it slid (slip).
    pub stick_frames: u64,
    /// Frames in which the tool slid against friction.
    pub slip_frames: u64,
    /// Frames whose device reading (time and pose) repeated the previous one: a stalled device.
    pub stalled_frames: u64,
    /// Wall time of the whole loop, s.
    pub wall_s: f64,
    /// The device's name (`replay`, `emulator`, ...).
    pub device: String,
    /// What the device link did: held and released frames, timeouts, masked axes.
    pub link: LinkStats,
}

/// The result of a loop run: every frame and the statistics.
#[derive(Clone, Debug, Default)]
pub struct LoopReport {
    /// Frame records, in order.
    pub frames: Vec<FrameRecord>,
    /// Statistics.
    pub stats: LoopStats,
}

/// Asks for `SCHED_FIFO` at `priority` for the calling thread; true on success.
#[cfg(target_os = "linux")]
pub fn set_realtime_priority(priority: i32) -> bool {
    // SAFETY: plain FFI calls on the current thread with a fully initialised parameter.
    unsafe {
        let param = libc::sched_param {
            sched_priority: priority,
        };
        libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) == 0
    }
}

/// Real-time priority is only implemented on Linux.
#[cfg(not(target_os = "linux"))]
pub fn set_realtime_priority(_priority: i32) -> bool {
    false
}

/// How long before a deadline a paced loop stops sleeping and spins, µs, by default (both
/// haptic loops: `haptic6d run --realtime` and `haptic6d serve`): the range's most, so that at
/// any haptic rate the loop naps [`NAP_US`] after each frame and then spins through the rest
/// of the wait, handing it to the engine's background work ([`Pacer::wait_warming`]). Measured
/// on a 2-core machine (docs/design-notes.md §The paced loop): a thread that sleeps until
/// 400 µs before its deadline wakes on a cold core and starts its background work late (paced spline p99
/// 201–299 µs against 156–199, least to median of 8 runs). It costs a core; 400 shares it
/// (sleep alone wakes ~50–100 µs late on a loaded Linux box).
pub const DEFAULT_SPIN_US: f64 = 10_000.0;

/// The nap after each frame, µs, when the deadline is at least [`NAP_MIN_SPIN_US`] further
/// off: a `SCHED_FIFO` thread that never sleeps is throttled by the kernel's real-time limit
/// (Linux: 950 ms in every second; measured: 48 ms gaps between frames). With a
/// nap of 100 µs in every 1 ms frame the loop runs at most 90 % of the time.
pub const NAP_US: u64 = 100;

/// Whether the kernel stops real-time threads that run too long without sleeping (Linux: its
/// `/proc/sys/kernel/sched_rt_runtime_us` is not `-1`). Unreadable, or on another system,
/// assumed so. Read once a process (the first call allocates).
pub fn rt_throttled() -> bool {
    static THROTTLED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *THROTTLED.get_or_init(|| {
        std::fs::read_to_string("/proc/sys/kernel/sched_rt_runtime_us")
            .map_or(true, |v| v.trim() != "-1")
    })
}

/// The nap a paced loop takes after each frame ([`Pacer::with_nap`]): [`NAP_US`], or none
/// where the kernel lets real-time threads run unthrottled ([`rt_throttled`]) and the machine
/// has a CPU besides the loop's, which then spins through its whole wait and keeps its core
/// (the rig's choice: `sysctl kernel.sched_rt_runtime_us=-1`). Measured on a 2-core virtual
/// machine (docs/design-notes.md §The paced loop): the bunny on its mesh, paced, p99 29–41
/// against 46–91 µs napping (medians of four sets of three or four runs).
pub fn loop_nap() -> Duration {
    if rt_runs_unbroken() {
        Duration::ZERO
    } else {
        Duration::from_micros(NAP_US)
    }
}

/// Whether a real-time loop may run without ever sleeping: the kernel does not throttle
/// real-time threads ([`rt_throttled`]) and the machine has a CPU besides the loop's. Read
/// once a process (the first call allocates).
pub fn rt_runs_unbroken() -> bool {
    static UNBROKEN: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *UNBROKEN.get_or_init(|| {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        runs_unbroken(rt_throttled(), cpus)
    })
}

/// [`rt_runs_unbroken`] for a kernel that throttles real-time threads or not, and `cpus` CPUs.
fn runs_unbroken(throttled: bool, cpus: usize) -> bool {
    !throttled && cpus >= 2
}

/// An unpaced loop asked to run at a real-time priority rests [`UNPACED_REST`] after each
/// [`UNPACED_RUN`] of frames, between two frames: a `SCHED_FIFO` thread that never sleeps is
/// stopped by the kernel's real-time limit (Linux: 950 ms in every second) for ~50 ms, inside
/// whichever frame it is running (`haptic6d run fit/round-r10-c0.02 --geometry mesh`, 3.6 s
/// of frames: frames of 47–51 ms, one or two a run). A rest of 100 ms after 800 ms keeps any
/// second's running under 900 ms; the frames' times are unchanged, the run takes ~12 % longer.
/// None where the kernel does not throttle real-time threads ([`rt_runs_unbroken`]).
pub const UNPACED_RUN: Duration = Duration::from_millis(800);

/// The rest of an unpaced real-time loop (see [`UNPACED_RUN`]).
pub const UNPACED_REST: Duration = Duration::from_millis(100);

/// When an unpaced loop at a real-time priority rests ([`UNPACED_RUN`]).
#[derive(Clone, Copy, Debug)]
struct UnpacedRests {
    /// Running since (the loop's start, or its last rest).
    since: Instant,
}

impl UnpacedRests {
    /// Whether a rest is due at `now`, and if so, counts it as taken.
    fn due(&mut self, now: Instant) -> bool {
        let due = now.saturating_duration_since(self.since) >= UNPACED_RUN;
        if due {
            self.since = now + UNPACED_REST;
        }
        due
    }
}

/// Least time (µs) left before the deadline after a nap: a frame that leaves less takes no nap
/// (a sleep may wake that late).
pub const NAP_MIN_SPIN_US: u64 = 300;

/// How long before a deadline a warm-up in [`Pacer::wait_warming`] must end, µs (a chunk's
/// reads past its limit cannot delay the frame).
pub const WARM_STOP_EARLY_US: u64 = 20;

/// The pacing of a haptic loop, shared by [`run_frames`] and the viewer's loop: frame `i`
/// starts at its deadline, `start + i` periods; the thread sleeps until `spin` before it (and
/// for [`NAP_US`] at least, where the wait leaves room), then spins. A frame that ends after
/// the next deadline is an overrun; a loop more than a whole period behind re-bases its
/// schedule on the current time (no burst of catch-up frames).
#[derive(Clone, Copy, Debug)]
pub struct Pacer {
    period: Duration,
    spin: Duration,
    nap: Duration,
    deadline: Instant,
}

impl Pacer {
    /// A schedule of `period` starting now; `spin` before each deadline is spent spinning,
    /// after a nap of [`NAP_US`].
    pub fn new(period: Duration, spin: Duration) -> Self {
        Self {
            period,
            spin,
            nap: Duration::from_micros(NAP_US),
            deadline: Instant::now(),
        }
    }

    /// The same schedule napping `nap` after each frame instead ([`loop_nap`]; zero: none,
    /// for a real-time thread only where the kernel does not throttle it).
    pub fn with_nap(self, nap: Duration) -> Self {
        Self { nap, ..self }
    }

    /// Waits until the current frame's deadline (returns at once when it has passed).
    ///
    /// # Real-time
    /// No allocation; sleeps, then spins.
    pub fn wait(&self) {
        self.wait_warming(|_| {});
    }

    /// [`Pacer::wait`], calling `warm` once as the spin begins with the time it must return
    /// by ([`WARM_STOP_EARLY_US`] before the deadline): the wait's idle time lets the caches
    /// go cold, and a frame that starts from memory is slower; the haptic loops pass
    /// [`engine::Engine::idle`] (the background detection work, then the caches warmed),
    /// [`engine::Engine::warm_caches`] warms them alone.
    ///
    /// # Real-time
    /// No allocation; sleeps, warms, then spins.
    pub fn wait_warming(&self, mut warm: impl FnMut(Instant)) {
        let Some(left) = self.deadline.checked_duration_since(Instant::now()) else {
            return;
        };
        // Asleep until the spin, and for the nap at least where the wait leaves room for it.
        let nap = if left >= self.nap + Duration::from_micros(NAP_MIN_SPIN_US) {
            self.nap
        } else {
            Duration::ZERO
        };
        let asleep = left.saturating_sub(self.spin).max(nap);
        if !asleep.is_zero() {
            std::thread::sleep(asleep);
        }
        let mut warmed = false;
        loop {
            let now = Instant::now();
            if now >= self.deadline {
                return;
            }
            let left = self.deadline - now;
            if !warmed {
                warmed = true;
                let early = Duration::from_micros(WARM_STOP_EARLY_US);
                if left > early {
                    warm(self.deadline - early);
                }
            } else {
                // Spins when the core is free; on a busy machine lets other threads run.
                std::thread::yield_now();
            }
        }
    }

    /// Ends the current frame: the next deadline is one period later (deadlines advance by
    /// addition, no `period * i` that could overflow). Returns true when the frame ended after
    /// that deadline (an overrun).
    pub fn end_frame(&mut self) -> bool {
        let end = Instant::now();
        let next = self.deadline.checked_add(self.period).unwrap_or(end);
        self.deadline = next;
        if end <= next {
            return false;
        }
        if end > next.checked_add(self.period).unwrap_or(end) {
            self.deadline = end;
        }
        true
    }
}

/// Runs frames of `engine` on the current thread until the device ends or `records` is full.
///
/// Each frame reads the device through a [`DeviceLink`] (calibration to the scene frame; a
/// missing reading holds the last pose up to [`DeviceSettings::timeout_s`], then releases the
/// wrench with [`Engine::release`], and the first reading after that restarts the soft start),
/// steps the engine and writes the wrench back through the link (to the device frame, axes the
/// device cannot render zeroed). Returns the frames run and the link's counts.
///
/// The safety filter's clock is the loop's own: wall time when paced, `frame / rate_hz` when
/// not; never the device's time stamps, so a recording whose times are all equal or negative
/// still gets its soft start once, at the beginning.
///
/// `params` should have passed [`LoopParams::validate`] ([`run_loop`] checks it); a rate
/// outside [`engine::config::RATE_HZ`] is paced at 1 kHz rather than panicking.
///
/// # Real-time
/// Allocation-free when `records` has spare capacity: the body is [`Engine::step`] and the
/// device calls. No panic, no arithmetic that can overflow.
pub fn run_frames<D: Device + ?Sized>(
    engine: &mut Engine,
    device: &mut D,
    params: &LoopParams,
    records: &mut Vec<FrameRecord>,
) -> (usize, LinkStats) {
    let period = params.pacing.period();
    let rate_hz = params.pacing.effective_rate_hz();
    let start = Instant::now();
    let nap = if params.realtime {
        loop_nap()
    } else {
        Duration::from_micros(NAP_US)
    };
    let mut pacer = Pacer::new(period, params.pacing.spin()).with_nap(nap);
    let mut last_start: Option<Instant> = None;
    let mut frame = 0usize;
    let mut link = DeviceLink::new(device, params.device);
    let mut rests =
        (!params.realtime && params.pacing.rt_priority.is_some() && !rt_runs_unbroken())
            .then_some(UnpacedRests { since: start });
    while records.len() < records.capacity() {
        if params.realtime {
            pacer.wait_warming(|until| engine.idle(until));
        } else if rests.as_mut().is_some_and(|r| r.due(Instant::now())) {
            std::thread::sleep(UNPACED_REST);
        }
        let now = Instant::now();
        let t_wall = (now - start).as_secs_f64();
        let t_rel = if params.realtime {
            t_wall
        } else {
            frame as f64 / rate_hz
        };
        let (t_dev, out) = match link.read(frame, t_rel) {
            LinkRead::Ended => break,
            LinkRead::Step { sample, flags } => {
                if flags & crate::device::link_flags::RESUMED != 0 {
                    engine.restart_soft_start();
                }
                (sample.t, *engine.step(t_rel, &sample.pose))
            }
            LinkRead::Release => (t_rel, *engine.release(t_rel)),
        };
        link.write(&out.wrench);
        let period_us = last_start.map_or(0.0, |l| (now - l).as_secs_f64() * 1e6);
        last_start = Some(now);
        let overrun = params.realtime && pacer.end_frame();
        records.push(FrameRecord {
            t: t_dev,
            t_wall,
            frame: out,
            period_us,
            overrun,
            link: link.flags(),
        });
        frame = frame.saturating_add(1);
    }
    (frame, *link.stats())
}

/// Runs the loop on a named thread (`haptic6d-rt`) and returns every frame and the statistics.
/// Storage for the records is reserved before the thread starts.
pub fn run_loop<D: Device>(
    engine: &mut Engine,
    device: &mut D,
    params: &LoopParams,
) -> Result<LoopReport, SceneError> {
    // The engine checked its settings when made; the loop's own against the same ranges as
    // the scene file, before the thread starts.
    params.validate()?;
    let mut rt_priority = false;
    let cap = device
        .frames()
        .unwrap_or(params.max_frames)
        .min(params.max_frames);
    // A recording too large for the memory is an error, not an abort.
    let mut records = Vec::new();
    records
        .try_reserve_exact(cap)
        .map_err(|_| engine::config::SettingError {
            key: "max_frames".into(),
            value: cap.to_string(),
            expected: format!(
                "at most the frames whose records fit in memory ({} bytes each)",
                std::mem::size_of::<FrameRecord>()
            ),
        })?;
    device.open()?;
    let t0 = Instant::now();
    let mut link = LinkStats::default();
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("haptic6d-rt".into())
            .spawn_scoped(s, || {
                if let Some(p) = params.pacing.rt_priority {
                    rt_priority = set_realtime_priority(p);
                }
                link = run_frames(engine, device, params, &mut records).1;
            })
            .map_err(SceneError::ThreadStart)?
            .join()
            .map_err(|_| SceneError::ThreadPanicked)
    })?;
    device.close();
    let wall_s = t0.elapsed().as_secs_f64();
    let nominal = 1e6 / params.pacing.rate_hz;
    let counts = Counters::of(records.iter().map(|r| r.frame.status));
    let stats = LoopStats {
        frames: records.len(),
        realtime: params.realtime,
        rt_priority,
        rate_hz: params.pacing.rate_hz,
        overruns: records.iter().filter(|r| r.overrun).count() as u64,
        period_error_us: if params.realtime {
            Summary::of(
                records
                    .iter()
                    .skip(1)
                    .map(|r| (r.period_us - nominal).abs()),
            )
        } else {
            Summary::default()
        },
        period_us: Summary::of(records.iter().skip(1).map(|r| r.period_us)),
        safety: engine.counters().safety,
        kept_last_safe: counts.kept_last_safe,
        pair_overflows: counts.pair_overflows,
        inexact: counts.inexact,
        lagging: counts.lagging,
        stick_frames: records
            .iter()
            .filter(|r| r.frame.friction == engine::FrictionState::Stick)
            .count() as u64,
        slip_frames: records
            .iter()
            .filter(|r| r.frame.friction == engine::FrictionState::Slip)
            .count() as u64,
        stalled_frames: records
            .windows(2)
            .filter(|w| w[1].t == w[0].t && w[1].frame.q_h == w[0].frame.q_h)
            .count() as u64,
        wall_s,
        device: device.name().to_string(),
        link,
    };
    Ok(LoopReport {
        frames: records,
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An unpaced real-time loop rests once per [`UNPACED_RUN`] of running, counted from the
    /// end of its last rest.
    #[test]
    fn an_unpaced_real_time_loop_rests_after_each_run_of_frames() {
        let start = Instant::now();
        let mut rests = UnpacedRests { since: start };
        let ms = |n: u64| start + Duration::from_millis(n);
        assert!(!rests.due(ms(0)));
        assert!(!rests.due(ms(799)));
        assert!(rests.due(ms(800)));
        // Resting until 900 ms: the next one is due 800 ms after that.
        assert!(!rests.due(ms(900)));
        assert!(!rests.due(ms(1699)));
        assert!(rests.due(ms(1750)));
        assert!(!rests.due(ms(1850)));
        assert!(rests.due(ms(2650)));
        // Frames of 0.7 ms for 10 s: no second, wherever it starts, holds more than 900 ms of
        // running (the kernel's limit is 950 ms in each of its periods).
        let frame = Duration::from_micros(700);
        let mut rests = UnpacedRests { since: start };
        let (mut now, mut running) = (start, Vec::new());
        while now < start + Duration::from_secs(10) {
            if rests.due(now) {
                now += UNPACED_REST;
            } else {
                running.push(now);
                now += frame;
            }
        }
        let mut most = 0;
        for (i, &from) in running.iter().enumerate() {
            let within = running[i..]
                .iter()
                .take_while(|&&t| t + frame <= from + Duration::from_secs(1))
                .count();
            most = most.max(within);
        }
        assert!(
            most as u32 * frame <= Duration::from_millis(900),
            "{most} frames"
        );
        assert!(
            most as u32 * frame >= Duration::from_millis(850),
            "{most} frames"
        );
    }

    #[test]
    fn a_paced_wait_warms_once_and_returns_at_its_deadline() {
        let period = Duration::from_millis(2);
        let spin = Duration::from_micros(800);
        let mut pacer = Pacer::new(period, spin);
        pacer.end_frame();
        let deadline = pacer.deadline;
        let mut calls = Vec::new();
        pacer.wait_warming(|until| calls.push((Instant::now(), until)));
        let woke = Instant::now();
        assert!(woke >= deadline, "returned before the deadline");
        // Once, as the spin begins (a thread preempted past that point may find no time left
        // and skip it), with a limit short of the deadline.
        assert!(calls.len() <= 1, "{} calls", calls.len());
        for (at, until) in calls {
            assert!(at + spin >= deadline, "warmed before the spin");
            assert_eq!(until + Duration::from_micros(WARM_STOP_EARLY_US), deadline);
        }
    }

    /// The loop naps unless the kernel lets real-time threads run unthrottled and another CPU
    /// is left to the rest of the machine; a wait without the nap keeps its deadline.
    #[test]
    fn a_loop_naps_unless_unthrottled_with_a_cpu_to_spare() {
        assert!(!runs_unbroken(true, 8));
        assert!(!runs_unbroken(true, 1));
        assert!(!runs_unbroken(false, 1));
        assert!(runs_unbroken(false, 2));
        let spin = Duration::from_secs_f64(DEFAULT_SPIN_US * 1e-6);
        let mut pacer = Pacer::new(Duration::from_millis(1), spin).with_nap(Duration::ZERO);
        for _ in 0..3 {
            pacer.end_frame();
            let deadline = pacer.deadline;
            let mut calls = 0;
            pacer.wait_warming(|until| {
                calls += 1;
                assert_eq!(until + Duration::from_micros(WARM_STOP_EARLY_US), deadline);
            });
            assert!(Instant::now() >= deadline && calls <= 1);
        }
    }

    /// A spin longer than the period (the default) still naps after each frame, so the loop is
    /// never throttled as a real-time thread that never sleeps; a wait too short for the nap
    /// (which it skips) still warms at most once, with the usual limit, and returns at its
    /// deadline.
    #[test]
    fn a_wait_that_spins_the_period_naps_first_unless_the_deadline_is_near() {
        let period = Duration::from_millis(1);
        let spin = Duration::from_secs_f64(DEFAULT_SPIN_US * 1e-6);
        assert!(spin > period);
        let mut pacer = Pacer::new(period, spin);
        pacer.end_frame();
        let (began, deadline) = (Instant::now(), pacer.deadline);
        let mut warmed = Vec::new();
        pacer.wait_warming(|until| warmed.push((Instant::now(), until)));
        assert!(Instant::now() >= deadline);
        // Once at most (a thread preempted through the whole wait finds no time left to warm
        // in), never before the nap is over.
        assert!(warmed.len() <= 1, "{} warm-ups", warmed.len());
        for (at, _) in warmed {
            assert!(
                at >= began + Duration::from_micros(NAP_US),
                "warmed before the nap"
            );
        }
        // Little time left (no nap): the same warm-up and the same deadline.
        let mut near = Pacer::new(Duration::from_micros(200), spin);
        near.end_frame();
        let deadline = near.deadline;
        let mut calls = 0;
        near.wait_warming(|until| {
            calls += 1;
            assert_eq!(until + Duration::from_micros(WARM_STOP_EARLY_US), deadline);
        });
        assert!(Instant::now() >= deadline);
        assert!(calls <= 1);
    }
}
