//! Queues between the real-time control loop and the threads below it
//! (the node's DDS thread, the check worker), none of whose operations on
//! the loop's side ever waits for the other side.
//!
//! `std::sync::mpsc` does not promise that: a receiver that finds a slot a
//! sender has claimed but not yet written spins until it is written (and a
//! sender, a slot a receiver is still reading). At real-time priority that
//! spin keeps the other thread from finishing when the loop preempted it on
//! its CPU and the other CPU is busy: on this 2-core machine at 20 kHz the
//! control loop spent seconds with 99.97 % of its samples in
//! `mpmc::array::Channel::try_recv`, the DDS thread never ran again and
//! SIGTERM went unanswered (BENCHMARKS.md "A loop that cannot keep its
//! rate"). So:
//!
//! - [`spsc`]: one producer, one consumer, on `rtrb`'s wait-free ring
//!   buffer; a full queue drops what is pushed (the caller counts it). The
//!   consumer can wait for the next item ([`Rx::wait`]) when the producer
//!   was given its thread ([`Tx::wake`]): a push then unparks it, which
//!   never waits either.
//! - [`commands`]: any number of producers (which may block on each other
//!   for the instant of a push), one consumer that only ever tries the
//!   lock and takes a held lock for an empty queue, so a command pushed
//!   while it was held is taken at the next cycle.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, TryLockError};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// The producer of a [`spsc`] queue.
pub struct Tx<T> {
    inner: rtrb::Producer<T>,
    wake: Option<Thread>,
}

/// The consumer of a [`spsc`] queue.
pub struct Rx<T> {
    inner: rtrb::Consumer<T>,
}

/// A queue of `capacity` items from one thread to one other.
pub fn spsc<T>(capacity: usize) -> (Tx<T>, Rx<T>) {
    let (p, c) = rtrb::RingBuffer::new(capacity);
    (
        Tx {
            inner: p,
            wake: None,
        },
        Rx { inner: c },
    )
}

impl<T> Tx<T> {
    /// Unparks `consumer` after each push, for a consumer that waits
    /// ([`Rx::wait`]).
    pub fn wake(mut self, consumer: Thread) -> Self {
        self.wake = Some(consumer);
        self
    }

    /// Pushes `item`; false when the queue is full (the item is dropped)
    /// or its consumer is gone.
    pub fn push(&mut self, item: T) -> bool {
        if self.inner.is_abandoned() {
            return false;
        }
        let ok = self.inner.push(item).is_ok();
        if let Some(t) = &self.wake {
            t.unpark();
        }
        ok
    }
}

/// The producer of a [`spsc`] queue is gone and everything it pushed was
/// taken.
#[derive(Debug, PartialEq)]
pub struct Gone;

impl<T> Rx<T> {
    /// The next item, if one is waiting; `Err(Gone)` once the producer is
    /// gone and the queue is empty.
    pub fn pop(&mut self) -> Result<Option<T>, Gone> {
        match self.inner.pop() {
            Ok(x) => Ok(Some(x)),
            // (abandoned is read after the pop: an item pushed before the
            // producer went is never lost)
            Err(_) if self.inner.is_abandoned() => match self.inner.pop() {
                Ok(x) => Ok(Some(x)),
                Err(_) => Err(Gone),
            },
            Err(_) => Ok(None),
        }
    }

    /// Waits up to `timeout` for an item: the next one, or None. Only for
    /// the thread its producer wakes ([`Tx::wake`]); it parks that thread.
    pub fn wait(&mut self, timeout: Duration) -> Result<Option<T>, Gone> {
        let until = Instant::now() + timeout;
        loop {
            if let Some(x) = self.pop()? {
                return Ok(Some(x));
            }
            let now = Instant::now();
            if now >= until {
                return Ok(None);
            }
            // (a push between the pop and the park leaves the token: the
            // park returns at once)
            std::thread::park_timeout(until - now);
        }
    }
}

struct Shared<T> {
    queue: Mutex<VecDeque<T>>,
    senders: AtomicUsize,
}

/// A producer of a [`commands`] queue (cloned for each thread).
pub struct CmdTx<T> {
    shared: Arc<Shared<T>>,
}

/// The consumer of a [`commands`] queue: the control loop.
pub struct CmdRx<T> {
    shared: Arc<Shared<T>>,
}

/// A queue of commands from any threads to the control loop.
pub fn commands<T>() -> (CmdTx<T>, CmdRx<T>) {
    let shared = Arc::new(Shared {
        queue: Mutex::new(VecDeque::new()),
        senders: AtomicUsize::new(1),
    });
    (
        CmdTx {
            shared: shared.clone(),
        },
        CmdRx { shared },
    )
}

impl<T> Clone for CmdTx<T> {
    fn clone(&self) -> Self {
        self.shared.senders.fetch_add(1, Ordering::AcqRel);
        CmdTx {
            shared: self.shared.clone(),
        }
    }
}

impl<T> Drop for CmdTx<T> {
    fn drop(&mut self) {
        self.shared.senders.fetch_sub(1, Ordering::AcqRel);
    }
}

impl<T> CmdTx<T> {
    /// Queues `cmd`; Err(cmd) when the consumer is gone.
    pub fn send(&self, cmd: T) -> Result<(), T> {
        if Arc::strong_count(&self.shared) == self.shared.senders.load(Ordering::Acquire) {
            return Err(cmd);
        }
        // (a panic elsewhere while holding the lock left a queue that is
        // still whole: a push or a pop is one VecDeque call)
        let mut q = self.shared.queue.lock().unwrap_or_else(|e| e.into_inner());
        q.push_back(cmd);
        Ok(())
    }
}

/// What [`CmdRx::try_recv`] found besides a command.
#[derive(Debug, PartialEq)]
pub enum NoCmd {
    /// none waiting, or a producer holds the queue this instant
    Empty,
    /// every producer is gone and the queue is empty
    Gone,
}

impl<T> CmdRx<T> {
    /// The next command, without waiting: a queue a producer holds this
    /// instant counts as empty (its command comes at the next try).
    pub fn try_recv(&self) -> Result<T, NoCmd> {
        let mut q = match self.shared.queue.try_lock() {
            Ok(q) => q,
            Err(TryLockError::Poisoned(e)) => e.into_inner(),
            Err(TryLockError::WouldBlock) => return Err(NoCmd::Empty),
        };
        match q.pop_front() {
            Some(c) => Ok(c),
            None if self.shared.senders.load(Ordering::Acquire) == 0 => Err(NoCmd::Gone),
            None => Err(NoCmd::Empty),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spsc_keeps_order_drops_when_full_and_tells_the_end_after_the_last() {
        let (mut tx, mut rx) = spsc::<u32>(3);
        assert_eq!(rx.pop(), Ok(None));
        assert!(tx.push(1) && tx.push(2) && tx.push(3));
        // full: the fourth is dropped
        assert!(!tx.push(4));
        assert_eq!(rx.pop(), Ok(Some(1)));
        assert!(tx.push(5));
        drop(tx);
        // what was pushed before the producer went still comes, in order
        assert_eq!(rx.pop(), Ok(Some(2)));
        assert_eq!(rx.pop(), Ok(Some(3)));
        assert_eq!(rx.pop(), Ok(Some(5)));
        assert_eq!(rx.pop(), Err(Gone));
        assert_eq!(rx.wait(Duration::from_secs(5)), Err(Gone));
    }

    #[test]
    fn a_push_to_a_gone_consumer_fails() {
        let (mut tx, rx) = spsc::<u32>(3);
        drop(rx);
        assert!(!tx.push(1));
    }

    /// A producer as fast as it goes (the control loop catching up) and a
    /// consumer that waits as the node's DDS thread does: every item
    /// arrives once, in order, and the end is told after the last.
    #[test]
    fn a_waiting_consumer_gets_every_item_then_the_end() {
        let (tx, mut rx) = spsc::<u64>(64);
        let mut tx = tx.wake(std::thread::current());
        let producer = std::thread::spawn(move || {
            let mut n = 0u64;
            while n < 20_000 {
                if tx.push(n) {
                    n += 1;
                } else {
                    std::thread::yield_now();
                }
            }
        });
        let mut next = 0u64;
        loop {
            match rx.wait(Duration::from_millis(20)) {
                Ok(Some(x)) => {
                    assert_eq!(x, next);
                    next += 1;
                }
                Ok(None) => {}
                Err(Gone) => break,
            }
        }
        assert_eq!(next, 20_000);
        producer.join().unwrap();
    }

    #[test]
    fn a_wait_with_nothing_pushed_times_out() {
        let (_tx, mut rx) = spsc::<u8>(4);
        let t0 = Instant::now();
        assert_eq!(rx.wait(Duration::from_millis(30)), Ok(None));
        assert!(t0.elapsed() >= Duration::from_millis(30));
    }

    #[test]
    fn commands_come_in_order_from_any_producer_and_a_held_queue_is_empty() {
        let (tx, rx) = commands::<&str>();
        let tx2 = tx.clone();
        assert_eq!(rx.try_recv(), Err(NoCmd::Empty));
        tx.send("start").unwrap();
        tx2.send("hold").unwrap();
        // a producer holding the queue this instant: the consumer does not
        // wait for it
        {
            let _held = tx.shared.queue.lock().unwrap();
            assert_eq!(rx.try_recv(), Err(NoCmd::Empty));
        }
        assert_eq!(rx.try_recv(), Ok("start"));
        assert_eq!(rx.try_recv(), Ok("hold"));
        drop(tx);
        assert_eq!(rx.try_recv(), Err(NoCmd::Empty));
        tx2.send("abort").unwrap();
        drop(tx2);
        // the last command before the producers went, then the end
        assert_eq!(rx.try_recv(), Ok("abort"));
        assert_eq!(rx.try_recv(), Err(NoCmd::Gone));
    }

    #[test]
    fn a_command_to_a_gone_loop_comes_back() {
        let (tx, rx) = commands::<u8>();
        drop(rx);
        assert_eq!(tx.send(7), Err(7));
    }
}
