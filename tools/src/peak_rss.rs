//! The process's resident memory from /proc/self/status on Linux (`None` elsewhere): the peak
//! (`peak_rss_bytes` in `build --json`, `gen mesh --json`, `render --json`: VmHWM), and the
//! current split into anonymous and file-backed pages (`MemoryNow`: RssAnon counts the heap
//! and, on a CPU adapter such as lavapipe, the "GPU" buffers; RssFile the map's touched pages,
//! which the kernel can drop and re-read). The kernel keeps no peak of RssAnon: `AnonPeak`
//! samples it, so its maximum is a lower bound of the true peak.

use tessera_preprocess::external::temp_usage::{self, TempKind};

/// Peak resident set size in bytes, where the system says.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_vm_hwm(&status)
}

/// Peak resident memory of each stage of a run. With `per_stage`, at every stage's start the
/// kernel's peak (VmHWM) is read for the stage that ends and reset to the current RSS
/// (`/proc/self/clear_refs`, Linux), so each figure is that stage's own peak. The reset also
/// resets the peak the kernel reports when the process exits (`ru_maxrss`), so that
/// `/usr/bin/time -v` would see only the last stage's: it is opt-in (`build --stage-peaks`).
/// Without it, or where the reset is not possible, the figures are the peak so far (`reset`
/// says which).
pub struct StagePeaks {
    state: std::sync::Mutex<PeakState>,
    pub reset: bool,
}

/// The stage running (if any) and the (stage, peak bytes) of those ended.
type PeakState = (Option<String>, Vec<(String, u64)>);

/// A stage's most temporary bytes (`temp_usage::stage_peak`) and what each kind of file held
/// then.
pub type TempStagePeak = (String, u64, Vec<(TempKind, u64)>);

/// Each ended stage's [`TempStagePeak`], in order.
static TEMP_STAGE_PEAKS: std::sync::Mutex<Vec<TempStagePeak>> = std::sync::Mutex::new(Vec::new());

/// The most the build's temporary files held during each stage that ended (every stage's own,
/// whatever `--stage-peaks`: the temporary totals cost nothing to reset).
pub fn temp_stage_peaks() -> Vec<TempStagePeak> {
    TEMP_STAGE_PEAKS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone()
}

fn end_temp_stage(stage: String) {
    let peak = temp_usage::stage_peak();
    let parts = temp_usage::by_kind_at_stage_peak();
    TEMP_STAGE_PEAKS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((stage, peak, parts));
    temp_usage::start_stage();
}

impl StagePeaks {
    pub fn new(per_stage: bool) -> Self {
        StagePeaks {
            state: std::sync::Mutex::new((None, Vec::new())),
            reset: per_stage && reset_peak(),
        }
    }

    /// Ends the current stage (if any) and starts `name`.
    pub fn start(&self, name: &str) {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(previous) = state.0.take() {
            let peak = peak_rss_bytes().unwrap_or(0);
            end_temp_stage(previous.clone());
            state.1.push((previous, peak));
        } else {
            temp_usage::start_stage();
        }
        if self.reset {
            reset_peak();
        }
        state.0 = Some(name.to_string());
    }

    /// Ends the last stage; (stage, peak bytes) in order.
    pub fn finish(&self) -> Vec<(String, u64)> {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(previous) = state.0.take() {
            let peak = peak_rss_bytes().unwrap_or(0);
            end_temp_stage(previous.clone());
            state.1.push((previous, peak));
        }
        state.1.clone()
    }
}

/// Resets VmHWM to the current RSS; false where the system does not allow it.
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn parse_vm_hwm(status: &str) -> Option<u64> {
    status_field(status, "VmHWM")
}

/// A `Name:   N kB` line of /proc/self/status, in bytes.
fn status_field(status: &str, name: &str) -> Option<u64> {
    let line = status
        .lines()
        .find(|l| l.strip_prefix(name).is_some_and(|r| r.starts_with(':')))?;
    let kb = line[name.len() + 1..].trim().strip_suffix("kB")?.trim();
    kb.parse::<u64>().ok().map(|kb| kb * 1024)
}

/// Resident memory now, bytes: VmRSS = RssAnon + RssFile + RssShmem, and the peak VmHWM.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryNow {
    pub rss: u64,
    pub rss_anon: u64,
    pub rss_file: u64,
    pub peak_rss: u64,
}

impl MemoryNow {
    /// Read from /proc/self/status; `None` where the system does not say.
    pub fn read() -> Option<MemoryNow> {
        let status = std::fs::read_to_string("/proc/self/status").ok()?;
        parse_memory(&status)
    }

    /// The JSON keys every command reporting memory uses.
    pub fn json(now: Option<MemoryNow>, anon_peak: Option<u64>) -> serde_json::Value {
        serde_json::json!({
            "peak_rss_bytes": now.map(|m| m.peak_rss),
            "rss_bytes": now.map(|m| m.rss),
            "rss_anon_bytes": now.map(|m| m.rss_anon),
            "rss_file_bytes": now.map(|m| m.rss_file),
            "rss_anon_peak_sampled_bytes": anon_peak,
        })
    }
}

fn parse_memory(status: &str) -> Option<MemoryNow> {
    Some(MemoryNow {
        rss: status_field(status, "VmRSS")?,
        rss_anon: status_field(status, "RssAnon")?,
        rss_file: status_field(status, "RssFile")?,
        peak_rss: status_field(status, "VmHWM")?,
    })
}

/// The largest RssAnon seen by `sample` (a lower bound of the true peak: the kernel keeps
/// none).
#[derive(Clone, Copy, Debug, Default)]
pub struct AnonPeak(Option<u64>);

impl AnonPeak {
    /// Reads RssAnon now and keeps the largest; returns the reading.
    pub fn sample(&mut self) -> Option<MemoryNow> {
        let now = MemoryNow::read();
        if let Some(m) = now {
            self.0 = Some(self.0.map_or(m.rss_anon, |p| p.max(m.rss_anon)));
        }
        now
    }

    pub fn bytes(&self) -> Option<u64> {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_vm_hwm() {
        let status = "Name:\ttessera\nVmPeak:\t  9000 kB\nVmHWM:\t    2048 kB\nVmRSS:\t 1 kB\n";
        assert_eq!(parse_vm_hwm(status), Some(2 * 1024 * 1024));
        assert_eq!(parse_vm_hwm("VmRSS: 1 kB"), None);
        let status = "VmHWM:\t 8 kB\nVmRSS:\t 6 kB\nRssAnon:\t 4 kB\nRssFile:\t 2 kB\n";
        assert_eq!(
            parse_memory(status),
            Some(MemoryNow {
                rss: 6 << 10,
                rss_anon: 4 << 10,
                rss_file: 2 << 10,
                peak_rss: 8 << 10
            })
        );
        // "RssAnon" must not match a longer name.
        assert_eq!(status_field("RssAnonX:\t 4 kB\n", "RssAnon"), None);
        #[cfg(target_os = "linux")]
        assert!(peak_rss_bytes().unwrap() > 0);
        #[cfg(target_os = "linux")]
        {
            let mut peak = AnonPeak::default();
            let now = peak.sample().unwrap();
            assert!(now.rss_anon > 0 && now.rss >= now.rss_anon && now.peak_rss >= now.rss);
            assert_eq!(peak.bytes(), Some(now.rss_anon));
        }
    }
}
