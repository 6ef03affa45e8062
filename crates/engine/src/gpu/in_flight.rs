//! Batches submitted and not yet read back: what lets the host plan and record batch
//! k+1 while the device runs batch k.
//!
//! A batch ends with a copy of its bitmask into a mappable staging buffer
//! ([`submit_read`](super::readback::submit_read)), which returns as soon as the work
//! is submitted. The batch is then *in flight* until [`InFlight::take`] waits for it.
//!
//! Why two batches in flight may share every other buffer (inputs, bitmasks, atlas):
//! the queue runs submissions in order, wgpu puts a barrier between one submission's
//! use of a buffer or texture and the next one's, and inputs are written with
//! `queue.write_buffer`, which lands after every earlier submission has read them. A
//! buffer reallocated while a batch is in flight stays alive until that batch is done
//! (wgpu defers its destruction). The one thing that cannot be shared is the staging
//! buffer: it is being mapped for batch k while batch k+1 would copy into it. So each
//! batch in flight holds its own, taken from a pool and handed back when read.

use std::collections::VecDeque;

use super::arena::GrowBuffer;
use super::device::{GpuDevice, GpuError};
use super::readback::{PendingRead, readback_buffer};

/// The batches of one backend in flight, oldest first, and the free staging buffers.
pub(crate) struct InFlight {
    next_ticket: u64,
    flights: VecDeque<Flight>,
    free: Vec<GrowBuffer>,
}

/// One submitted batch.
struct Flight {
    ticket: u64,
    read: PendingRead,
    staging: GrowBuffer,
    /// Bitmask words per pose.
    words: u32,
}

impl InFlight {
    pub(crate) fn new() -> Self {
        InFlight {
            next_ticket: 1,
            flights: VecDeque::new(),
            free: Vec::new(),
        }
    }

    /// A staging buffer for the next batch's readback: a free one, or a new (empty)
    /// one when every buffer is in flight. The pool grows to the most batches ever in
    /// flight at once, then stays.
    pub(crate) fn staging(&mut self) -> GrowBuffer {
        self.free.pop().unwrap_or_else(readback_buffer)
    }

    /// Records a submitted batch whose bitmask (`words` per pose) `read` copies into
    /// `staging`; returns the ticket [`InFlight::take`] answers it for.
    pub(crate) fn push(&mut self, read: PendingRead, staging: GrowBuffer, words: u32) -> u64 {
        let ticket = self.next_ticket;
        self.next_ticket += 1;
        self.flights.push_back(Flight {
            ticket,
            read,
            staging,
            words,
        });
        ticket
    }

    /// How many batches are in flight.
    pub(crate) fn len(&self) -> usize {
        self.flights.len()
    }

    /// Waits for batch `ticket` and returns its bitmask, one `Vec` per pose. Batches
    /// submitted before it and never taken (their caller gave up on them) are waited
    /// for and dropped first, so that their staging buffers return to the pool.
    pub(crate) fn take(&mut self, gpu: &GpuDevice, ticket: u64) -> Result<Vec<Vec<u32>>, GpuError> {
        while let Some(flight) = self.flights.pop_front() {
            let Flight {
                ticket: t,
                read,
                staging,
                words,
            } = flight;
            // A failed wait leaves the staging buffer's mapping unknown: drop it.
            let bytes = read.wait(gpu)?;
            self.free.push(staging);
            if t != ticket {
                continue;
            }
            let all: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
            return Ok(all
                .chunks_exact(words.max(1) as usize)
                .map(<[u32]>::to_vec)
                .collect());
        }
        Err(GpuError::Readback(format!(
            "no batch in flight has ticket {ticket}"
        )))
    }
}
