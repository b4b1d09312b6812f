//! One page owns the device at a time. Pages (WebSocket connections) queue in the order they
//! connected: the first one is the owner — its poses, release, reset and record commands are
//! applied — and the others watch (they receive the state stream and may ask for contacts, but
//! their commands are ignored). When the owner closes, the device is released (its hold ends
//! with it, as when a single page closes) and the next page in the queue becomes the owner.
//! A watcher closing changes nothing for the owner.

use std::collections::VecDeque;
use std::sync::Mutex;

use tokio::sync::watch;

/// The queue of open pages and who owns the device.
pub struct PageSeats {
    queue: Mutex<Queue>,
    owner_tx: watch::Sender<u64>,
}

struct Queue {
    next_id: u64,
    open: VecDeque<u64>,
}

/// A page's role, as told to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// This page drives the device.
    Owner,
    /// This page watches; `ahead` pages are before it in the queue (the owner included).
    Watcher {
        /// Pages ahead in the queue.
        ahead: usize,
    },
}

impl Default for PageSeats {
    fn default() -> Self {
        Self::new()
    }
}

impl PageSeats {
    /// No page yet.
    pub fn new() -> Self {
        let (owner_tx, _) = watch::channel(0);
        Self {
            queue: Mutex::new(Queue {
                next_id: 1,
                open: VecDeque::new(),
            }),
            owner_tx,
        }
    }

    /// A new page joins the queue; returns its id (never 0).
    pub fn join(&self) -> u64 {
        let mut q = self.queue.lock().unwrap_or_else(|p| p.into_inner());
        let id = q.next_id;
        q.next_id += 1;
        q.open.push_back(id);
        let owner = q.open.front().copied().unwrap_or(0);
        self.owner_tx.send_replace(owner);
        id
    }

    /// Page `id` leaves; returns true when it was the owner (the caller then releases the
    /// device). The next page, if any, becomes the owner.
    pub fn leave(&self, id: u64) -> bool {
        let mut q = self.queue.lock().unwrap_or_else(|p| p.into_inner());
        let was_owner = q.open.front() == Some(&id);
        q.open.retain(|&k| k != id);
        let owner = q.open.front().copied().unwrap_or(0);
        self.owner_tx.send_replace(owner);
        was_owner
    }

    /// True when page `id` owns the device.
    pub fn is_owner(&self, id: u64) -> bool {
        *self.owner_tx.borrow() == id
    }

    /// Page `id`'s role now.
    pub fn role(&self, id: u64) -> Role {
        let q = self.queue.lock().unwrap_or_else(|p| p.into_inner());
        match q.open.iter().position(|&k| k == id) {
            Some(0) => Role::Owner,
            Some(ahead) => Role::Watcher { ahead },
            None => Role::Watcher {
                ahead: q.open.len(),
            },
        }
    }

    /// Changes whenever the queue changes (the owner's id, 0 for none).
    pub fn subscribe(&self) -> watch::Receiver<u64> {
        self.owner_tx.subscribe()
    }

    /// Open pages.
    pub fn open(&self) -> usize {
        self.queue
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .open
            .len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ownership_passes_in_connection_order_and_watchers_leave_quietly() {
        let s = PageSeats::new();
        let a = s.join();
        let b = s.join();
        let c = s.join();
        assert!(s.is_owner(a) && !s.is_owner(b));
        assert_eq!(s.role(c), Role::Watcher { ahead: 2 });
        assert!(!s.leave(b), "a watcher is not the owner");
        assert!(s.is_owner(a));
        assert_eq!(s.role(c), Role::Watcher { ahead: 1 });
        assert!(s.leave(a));
        assert!(s.is_owner(c));
        assert_eq!(s.role(c), Role::Owner);
        assert!(s.leave(c));
        assert_eq!(s.open(), 0);
        assert!(!s.is_owner(c));
    }
}
