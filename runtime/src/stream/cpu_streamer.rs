//! Streaming driven by the CPU traversal: frame by frame, the flags of the residency gate the
//! cut, the frame's feedback feeds the residency, and loads complete a fixed number of frames
//! after they were issued (read through the map, checksums checked, at completion time). The
//! same loop the GPU renderer runs, with the traversal on the CPU: the reference for tests
//! and for `bench stream`'s figures that do not depend on a GPU.

use std::collections::VecDeque;

use tessera_core::cull::CullTests;
use tessera_core::cut::diamond_rhos;
use tessera_core::metric::ScreenSpaceMetric;
use tessera_core::repository::{Repository, RepositoryError};

use super::cpu_frame::{stream_frame, StreamFrame};
use super::loader::read_unit;
use super::residency::{Residency, ResidencyStats};
use super::units::UnitTable;

/// How the streamer loads.
#[derive(Clone, Copy, Debug)]
pub struct StreamSettings {
    /// Bytes the resident units (and the pinned roots) may take.
    pub budget_bytes: u64,
    /// Bytes of loads issued per frame (at least one unit per frame when any is wanted).
    pub upload_bytes_per_frame: u64,
    /// Frames between issuing a load and its data being usable (≥ 1: the GPU's read-back of
    /// requests is a frame or two late).
    pub latency_frames: u64,
}

/// One frame's outcome.
#[derive(Debug)]
pub struct StreamedFrame {
    /// What the traversal selected and reported.
    pub frame: StreamFrame,
    /// The flags the frame was drawn with.
    pub may_refine: Vec<bool>,
    /// Units loaded (issued) and evicted by this frame's plan.
    pub loads: usize,
    pub loaded_bytes: u64,
    pub evictions: usize,
    /// Seconds spent reading (and decoding, when packed) the units that landed this frame.
    pub read_seconds: f64,
    /// Totals after the frame.
    pub stats: ResidencyStats,
}

/// The CPU streaming loop over one repository.
pub struct CpuStreamer<'r> {
    repo: &'r Repository,
    residency: Residency,
    settings: StreamSettings,
    in_flight: VecDeque<(u64, u32)>,
    frame: u64,
    /// Failed loads: the unit and why.
    pub failures: Vec<(u32, RepositoryError)>,
}

impl<'r> CpuStreamer<'r> {
    /// Every unit absent, the roots pinned; fails when the roots exceed the budget.
    pub fn new(repo: &'r Repository, settings: StreamSettings) -> Result<CpuStreamer<'r>, String> {
        let units = UnitTable::from_repository(repo);
        Ok(CpuStreamer {
            repo,
            residency: Residency::new(units, settings.budget_bytes)?,
            settings,
            in_flight: VecDeque::new(),
            frame: 0,
            failures: Vec::new(),
        })
    }

    /// The residency (flags, states, totals).
    pub fn residency(&self) -> &Residency {
        &self.residency
    }

    /// Draws one frame for an eye in the repository frame: completes the loads due, runs the
    /// traversal with the current flags, feeds back, plans loads and evictions.
    pub fn frame(
        &mut self,
        eye_local: [f32; 3],
        metric: &ScreenSpaceMetric,
        tau: f32,
        cull: &CullTests,
    ) -> StreamedFrame {
        self.frame += 1;
        let mut read_seconds = 0.0;
        while let Some(&(due, unit)) = self.in_flight.front() {
            if due > self.frame {
                break;
            }
            self.in_flight.pop_front();
            let simplices = self.residency.units().simplices(unit);
            let ok = match read_unit(self.repo, simplices) {
                Ok(read) => {
                    read_seconds += read.read_seconds;
                    true
                }
                Err(e) => {
                    self.failures.push((unit, e));
                    false
                }
            };
            self.residency.complete(unit, ok);
        }
        let rhos = diamond_rhos(self.repo.diamonds(), eye_local, metric);
        let may_refine = self.residency.may_refine().to_vec();
        let frame = stream_frame(
            self.repo.tets(),
            self.repo.header().root_tet_count as usize,
            &rhos,
            &may_refine,
            tau,
            eye_local,
            cull,
        );
        self.residency.feedback(&frame.refined, &frame.wanted);
        let plan = self.residency.plan(self.settings.upload_bytes_per_frame);
        let loaded_bytes = plan
            .load
            .iter()
            .map(|&u| self.residency.units().bytes(u))
            .sum();
        let due = self.frame + self.settings.latency_frames.max(1);
        self.in_flight.extend(plan.load.iter().map(|&u| (due, u)));
        StreamedFrame {
            frame,
            may_refine,
            loads: plan.load.len(),
            loaded_bytes,
            evictions: plan.evict.len(),
            read_seconds,
            stats: self.residency.stats(),
        }
    }
}
