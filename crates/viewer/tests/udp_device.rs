//! A device program speaking the UDP protocol drives a [`viewer::UdpDevice`] (the device trait's
//! side of the same protocol as the bridge): its session's poses are read once each, its
//! WRENCHes carry the wrench written, a BYE or a silence ends the session, and a second client
//! is refused while one holds it.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use scene::device::{Device, Reading};
use viewer::protocol::flags;
use viewer::{BridgeClient, UdpDevice};

/// Serves `device` on a thread (read, then write `wrench`, every 1 ms) until `stop`; returns
/// the z of every pose read.
fn serve(
    mut device: UdpDevice,
    wrench: [f64; 6],
    stop: Arc<AtomicBool>,
) -> std::thread::JoinHandle<(UdpDevice, Vec<f64>)> {
    std::thread::spawn(move || {
        let mut zs = Vec::new();
        let mut frame = 0;
        while !stop.load(Ordering::Acquire) {
            if let Reading::Pose(s) = device.read(frame, 0.0) {
                zs.push(s.pose.q[2]);
            }
            device.write_wrench(&wrench);
            frame += 1;
            std::thread::sleep(Duration::from_millis(1));
        }
        (device, zs)
    })
}

#[test]
fn a_client_session_drives_the_device_and_gets_its_wrench() {
    let mut device = UdpDevice::new(
        "127.0.0.1:0".parse::<SocketAddr>().unwrap(),
        Duration::from_millis(100),
    );
    assert!(
        matches!(device.read(0, 0.0), Reading::Pending),
        "not open yet"
    );
    device.open().unwrap();
    let addr = device.local_addr().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let server = serve(device, [1.0, -2.0, 3.0, 40.0, 0.0, 0.0], stop.clone());

    let mut client = BridgeClient::connect(addr, Duration::from_millis(100)).unwrap();
    assert!(client.open_session(Duration::from_secs(2)).unwrap());
    // A second program is refused while the first holds the session.
    let mut other = BridgeClient::connect(addr, Duration::from_millis(100)).unwrap();
    assert!(!other.open_session(Duration::from_millis(200)).unwrap());

    let mut last_force = [0.0; 3];
    for k in 0..200 {
        client
            .send_pose([0.0, 0.0, 10.0 + k as f64 * 0.01, 0.0, 0.0, 0.0])
            .unwrap();
        std::thread::sleep(Duration::from_millis(2));
        if let Some(w) = client.poll().unwrap() {
            if w.header.flags & flags::RELEASED == 0 {
                last_force = w.force;
            }
        }
    }
    assert_eq!(
        last_force,
        [1.0, -2.0, 3.0],
        "the WRENCH carries the wrench written"
    );
    client.bye().unwrap();
    std::thread::sleep(Duration::from_millis(20));
    stop.store(true, Ordering::Release);
    let (mut device, zs) = server.join().unwrap();
    assert!(zs.len() > 100, "{} poses read", zs.len());
    assert!(
        zs.windows(2).all(|w| w[1] > w[0]),
        "each pose read once, in order"
    );
    // After BYE: no pose, and the counters say what happened.
    assert!(matches!(device.read(0, 0.0), Reading::Pending));
    let s = device.stats();
    assert!(s.sessions.load(Ordering::Relaxed) >= 1 && s.busy.load(Ordering::Relaxed) >= 1);
    device.close();
}

#[test]
fn a_silent_client_loses_its_session_and_a_busy_address_is_one_line() {
    let mut device = UdpDevice::new(
        "127.0.0.1:0".parse::<SocketAddr>().unwrap(),
        Duration::from_millis(50),
    );
    device.open().unwrap();
    let addr = device.local_addr().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let server = serve(device, [0.5, 0.0, 0.0, 0.0, 0.0, 0.0], stop.clone());
    let mut client = BridgeClient::connect(addr, Duration::from_millis(50)).unwrap();
    assert!(client.open_session(Duration::from_secs(2)).unwrap());
    client.send_pose([0.0; 6]).unwrap();
    // Silent for longer than the timeout, then a pose: refused (no session).
    std::thread::sleep(Duration::from_millis(200));
    client.send_pose([0.0, 0.0, 1.0, 0.0, 0.0, 0.0]).unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    let mut refused = false;
    while Instant::now() < end && !refused {
        if let Some(w) = client.poll().unwrap() {
            refused = w.header.flags & flags::NO_SESSION != 0;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    assert!(refused, "the silent client kept its session");
    stop.store(true, Ordering::Release);
    let (device, _) = server.join().unwrap();
    assert!(device.stats().timeouts.load(Ordering::Relaxed) >= 1);
    // Its address is taken while it is open.
    let mut second = UdpDevice::new(addr, Duration::from_millis(50));
    let e = second.open().unwrap_err();
    let msg = scene::error_chain(&e);
    assert!(
        msg.contains("cannot listen on") && !msg.contains('\n'),
        "{msg}"
    );
}

/// A new session opened by the owner while it drives (a HELLO and the first POSE between two
/// reads of the loop) is a release frame first, then a resumed one: the run loop releases the
/// wrench and restarts the soft start, however soon the new session's POSE came.
#[test]
fn a_new_session_between_two_reads_is_released_then_resumed() {
    use scene::device::{link_flags, DeviceLink, DeviceSettings, LinkRead};
    let mut device = UdpDevice::new(
        "127.0.0.1:0".parse::<SocketAddr>().unwrap(),
        Duration::from_secs(5),
    );
    device.open().unwrap();
    let addr = device.local_addr().unwrap();
    let mut client = BridgeClient::connect(addr, Duration::from_secs(5)).unwrap();
    let mut link = DeviceLink::new(&mut device, DeviceSettings::default());
    // The session opens (the HELLO is handled by a read) and a POSE drives the link.
    client.hello().unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    let mut frame = 0;
    let mut read_until = |link: &mut DeviceLink<'_, UdpDevice>,
                          want: &dyn Fn(&LinkRead) -> bool| loop {
        let r = link.read(frame, frame as f64 * 1e-3);
        frame += 1;
        if want(&r) {
            return r;
        }
        assert!(Instant::now() < end, "no such reading: last {r:?}");
        std::thread::sleep(Duration::from_millis(1));
    };
    while !client.has_session() {
        let _ = read_until(&mut link, &|_| true);
        client.poll().unwrap();
    }
    client.send_pose([0.0, 0.0, 5.0, 0.0, 0.0, 0.0]).unwrap();
    let _ = read_until(&mut link, &|r| matches!(r, LinkRead::Step { .. }));
    // HELLO + POSE land together: the next read releases, the one after resumes.
    client.hello().unwrap();
    client.send_pose([0.0, 0.0, 4.0, 0.0, 0.0, 0.0]).unwrap();
    std::thread::sleep(Duration::from_millis(20));
    assert_eq!(
        link.read(frame, 1.0),
        LinkRead::Release,
        "the old session's end"
    );
    match link.read(frame + 1, 1.001) {
        LinkRead::Step { sample, flags } => {
            assert_eq!(sample.pose.q[2], 4.0);
            assert!(
                flags & link_flags::RESUMED != 0,
                "the soft start is asked for"
            );
        }
        r => panic!("the new session's pose was not read: {r:?}"),
    }
}
