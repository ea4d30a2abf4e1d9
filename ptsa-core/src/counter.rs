//! Gated pulse counts and a bounded queue that never loses one.

use heapless::Deque;

/// One closed counting gate: `pulses` data pulses over `ticks` clock ticks (`P` and `T` of
/// eqs. 6.1-6.4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gate {
    /// Data pulses (ticks of positive polarity) in the gate.
    pub pulses: u32,
    /// Clock ticks in the gate.
    pub ticks: u32,
}

/// Counts of one or more consecutive gates, as a [`GateFifo`] hands them out. When the
/// queue was full, consecutive gates were summed into one entry (`gates > 1`), so `P/T`
/// stays exact and no pulse is lost. 64-bit sums cannot overflow in 2^63 ticks (over four
/// million years at 64 kHz).
///
/// `seq` and `end_tick` place the entry in the stream of gates, so that a reader of the
/// reports (`ptsa record`) can tell a lost report from a merge: the gates of consecutive
/// entries are numbered `seq − gates + 1 ..= seq`, and `end_tick − ticks` is the previous
/// entry's `end_tick`. Both are `u64` and never wrap (2^64 ticks at 64 kHz are nine million
/// years).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Count {
    /// Data pulses.
    pub pulses: u64,
    /// Clock ticks.
    pub ticks: u64,
    /// Number of gates summed into this entry.
    pub gates: u32,
    /// Sequence number of the entry's last gate: gates closed since the queue was created,
    /// counting from 1 (the queue's first gate is 1).
    pub seq: u64,
    /// Clock ticks from the start of the queue's first gate to the close of this entry's
    /// last gate (the sum of the ticks of every gate pushed so far).
    pub end_tick: u64,
}

impl From<Gate> for Count {
    /// A lone gate as the first of its stream (`seq` 1, `end_tick` its ticks).
    fn from(g: Gate) -> Self {
        Self {
            pulses: u64::from(g.pulses),
            ticks: u64::from(g.ticks),
            gates: 1,
            seq: 1,
            end_tick: u64::from(g.ticks),
        }
    }
}

/// A FIFO of closed gates between the tick interrupt (producer) and the reporting loop
/// (consumer) that never drops a count: when the queue is full, a new gate is added into
/// the newest entry, so counts accumulate instead of being lost. It numbers the gates it is
/// given (`seq`) and sums their ticks (`end_tick`), so every entry says where it lies in
/// the stream.
///
/// ```
/// use ptsa_core::{Count, Gate, GateFifo};
/// let mut q: GateFifo<2> = GateFifo::new();
/// for _ in 0..5 {
///     q.push(Gate { pulses: 10, ticks: 20 });
/// }
/// assert_eq!(q.pop(), Some(Count { pulses: 10, ticks: 20, gates: 1, seq: 1, end_tick: 20 }));
/// assert_eq!(q.pop(), Some(Count { pulses: 40, ticks: 80, gates: 4, seq: 5, end_tick: 100 }));
/// assert_eq!(q.pop(), None);
/// assert_eq!(q.merges(), 3);
/// ```
#[derive(Clone, Debug, Default)]
pub struct GateFifo<const N: usize> {
    queue: Deque<Count, N>,
    merges: u32,
    /// Gates pushed so far.
    closed: u64,
    /// Their ticks, summed.
    elapsed: u64,
}

impl<const N: usize> GateFifo<N> {
    const CAPACITY: () = assert!(N >= 1, "GateFifo needs room for at least one entry");

    /// An empty queue.
    #[must_use]
    pub const fn new() -> Self {
        let () = Self::CAPACITY;
        Self {
            queue: Deque::new(),
            merges: 0,
            closed: 0,
            elapsed: 0,
        }
    }

    /// Queue a gate (numbered one more than the last, its close `gate.ticks` after the
    /// last's); when the queue is full, add it into the newest entry.
    pub fn push(&mut self, gate: Gate) {
        self.closed += 1;
        self.elapsed += u64::from(gate.ticks);
        let c = Count {
            seq: self.closed,
            end_tick: self.elapsed,
            ..Count::from(gate)
        };
        if let Err(c) = self.queue.push_back(c)
            && let Some(last) = self.queue.back_mut()
        {
            last.pulses += c.pulses;
            last.ticks += c.ticks;
            last.gates = last.gates.saturating_add(1);
            last.seq = c.seq;
            last.end_tick = c.end_tick;
            self.merges = self.merges.saturating_add(1);
        }
    }

    /// Take the oldest entry.
    pub fn pop(&mut self) -> Option<Count> {
        self.queue.pop_front()
    }

    /// Entries queued.
    #[must_use]
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// Whether nothing is queued.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// How many pushes found the queue full and were added into its newest entry.
    #[must_use]
    pub fn merges(&self) -> u32 {
        self.merges
    }
}
