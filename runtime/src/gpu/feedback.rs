//! Streaming feedback from the GPU traversal: the diamonds it refined and the ones it wanted
//! to refine but could not (`may_refine` clear), each with ρ/τ as f32, from simplices inside
//! the view volume (`shaders/traverse.wgsl`, `feed_back`). Two lists in one storage buffer
//! with a capacity each (appends past it are counted, not written: an overflowed frame just
//! requests less), copied after the frame's compute pass into one of a ring of MAP_READ
//! staging buffers and mapped without waiting; `take` polls the device (`PollType::Poll`) and
//! returns the frames whose copy is readable, a frame or two late. A frame that finds every
//! staging buffer busy sends no feedback.

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

use super::device::{GpuContext, GpuFailure};

/// Staging buffers in the ring.
pub const RING: usize = 3;
/// Words before the entries: refined count, wanted count, capacity, pad.
const HEADER_WORDS: u64 = 4;

/// One frame's feedback, as read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeedbackFrame {
    /// The renderer's frame number (`Renderer::frames_submitted` after its submit).
    pub frame: u64,
    pub refined: Vec<(u32, f32)>,
    pub wanted: Vec<(u32, f32)>,
    /// Appends that did not fit, over both lists.
    pub overflow: u32,
}

/// Map states of a staging buffer.
const IDLE: u8 = 0;
const COPIED: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;
const FAILED: u8 = 4;

struct Staging {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
    frame: u64,
}

/// The lists and their read-back ring.
pub struct Feedback {
    /// Bound by the traversal (binding 8).
    pub lists: wgpu::Buffer,
    capacity: u32,
    ring: Vec<Staging>,
    /// The staging buffer the latest frame copied into.
    pending: Option<usize>,
}

impl Feedback {
    /// Lists of `capacity` entries each (0: the traversal only counts).
    pub fn new(ctx: &GpuContext, capacity: u32) -> Feedback {
        use wgpu::util::DeviceExt;
        use wgpu::BufferUsages as U;
        let words = HEADER_WORDS + 4 * capacity as u64;
        let mut init = vec![0u32; words as usize];
        init[2] = capacity;
        let lists = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("streaming feedback"),
                contents: bytemuck::cast_slice(&init),
                usage: U::STORAGE | U::COPY_SRC | U::COPY_DST,
            });
        let ring = (0..if capacity == 0 { 0 } else { RING })
            .map(|_| Staging {
                buffer: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("streaming feedback read-back"),
                    size: words * 4,
                    usage: U::MAP_READ | U::COPY_DST,
                    mapped_at_creation: false,
                }),
                state: Arc::new(AtomicU8::new(IDLE)),
                frame: 0,
            })
            .collect();
        Feedback {
            lists,
            capacity,
            ring,
            pending: None,
        }
    }

    /// The largest capacity whose lists fit `binding` bytes (they are one storage binding).
    pub fn max_capacity(binding: u64) -> u32 {
        ((binding / 4).saturating_sub(HEADER_WORDS) / 4).min(u32::MAX as u64) as u32
    }

    /// Bytes this allocates on the GPU (the lists and the ring).
    pub fn bytes(capacity: u32) -> u64 {
        let words = HEADER_WORDS + 4 * capacity as u64;
        words * 4 * if capacity == 0 { 1 } else { 1 + RING as u64 }
    }

    /// Before the traversal: zero both counts (the capacity word stays).
    pub fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.lists, 0, Some(8));
    }

    /// After the traversal: copy the lists into an idle staging buffer, if any, for `frame`.
    pub fn copy_out(&mut self, encoder: &mut wgpu::CommandEncoder, frame: u64) {
        self.pending = None;
        let Some(k) = self
            .ring
            .iter()
            .position(|s| s.state.load(Ordering::Acquire) == IDLE)
        else {
            return;
        };
        encoder.copy_buffer_to_buffer(&self.lists, 0, &self.ring[k].buffer, 0, None);
        self.ring[k].state.store(COPIED, Ordering::Release);
        self.ring[k].frame = frame;
        self.pending = Some(k);
    }

    /// After the submit: start mapping what `copy_out` copied.
    pub fn after_submit(&mut self) {
        let Some(k) = self.pending.take() else {
            return;
        };
        let state = self.ring[k].state.clone();
        state.store(MAPPING, Ordering::Release);
        self.ring[k]
            .buffer
            .slice(..)
            .map_async(wgpu::MapMode::Read, move |result| {
                state.store(
                    if result.is_ok() { MAPPED } else { FAILED },
                    Ordering::Release,
                );
            });
    }

    /// The frames whose lists are readable now, oldest first (polls without waiting); an
    /// error when a map failed.
    pub fn take(&mut self, ctx: &GpuContext) -> Result<Vec<FeedbackFrame>, GpuFailure> {
        ctx.device
            .poll(wgpu::PollType::Poll)
            .map_err(|e| GpuFailure(format!("polling the device: {e}")))?;
        ctx.check()?;
        let mut out = Vec::new();
        for s in &mut self.ring {
            match s.state.load(Ordering::Acquire) {
                FAILED => {
                    ctx.wait_idle()?; // a device that failed says so once its queue is done
                    return Err(GpuFailure(
                        "reading back the streaming feedback failed: its buffer could not be \
                         mapped"
                            .into(),
                    ));
                }
                MAPPED => {}
                _ => continue,
            }
            let words: Vec<u32> = {
                let view =
                    s.buffer.slice(..).get_mapped_range().map_err(|e| {
                        GpuFailure(format!("reading back the streaming feedback: {e}"))
                    })?;
                bytemuck::pod_collect_to_vec(&view)
            };
            s.buffer.unmap();
            s.state.store(IDLE, Ordering::Release);
            let cap = self.capacity as usize;
            let list = |l: usize| -> Vec<(u32, f32)> {
                let n = (words[l] as usize).min(cap);
                let at = HEADER_WORDS as usize + 2 * l * cap;
                (0..n)
                    .map(|k| (words[at + 2 * k], f32::from_bits(words[at + 2 * k + 1])))
                    .collect()
            };
            let overflow =
                words[0].saturating_sub(self.capacity) + words[1].saturating_sub(self.capacity);
            out.push(FeedbackFrame {
                frame: s.frame,
                refined: list(0),
                wanted: list(1),
                overflow,
            });
        }
        out.sort_by_key(|f| f.frame);
        Ok(out)
    }
}
