//! The process's peak resident memory (`peak_rss_bytes` in `build --json` and
//! `gen mesh --json`): VmHWM from /proc/self/status on Linux, `None` elsewhere.

/// Peak resident set size in bytes, where the system says.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_vm_hwm(&status)
}

/// Peak resident memory of each stage of a run: at every stage's start the kernel's peak
/// (VmHWM) is read for the stage that ends and reset to the current RSS (`/proc/self/clear_refs`,
/// Linux), so each figure is that stage's own peak. Where the reset is not possible the
/// figures are the peak so far (`reset` says which).
pub struct StagePeaks {
    state: std::sync::Mutex<PeakState>,
    pub reset: bool,
}

/// The stage running (if any) and the (stage, peak bytes) of those ended.
type PeakState = (Option<String>, Vec<(String, u64)>);

impl StagePeaks {
    pub fn new() -> Self {
        StagePeaks {
            state: std::sync::Mutex::new((None, Vec::new())),
            reset: reset_peak(),
        }
    }

    /// Ends the current stage (if any) and starts `name`.
    pub fn start(&self, name: &str) {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(previous) = state.0.take() {
            let peak = peak_rss_bytes().unwrap_or(0);
            state.1.push((previous, peak));
        }
        reset_peak();
        state.0 = Some(name.to_string());
    }

    /// Ends the last stage; (stage, peak bytes) in order.
    pub fn finish(&self) -> Vec<(String, u64)> {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(previous) = state.0.take() {
            let peak = peak_rss_bytes().unwrap_or(0);
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
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb = line["VmHWM:".len()..].trim().strip_suffix("kB")?.trim();
    kb.parse::<u64>().ok().map(|kb| kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_vm_hwm() {
        let status = "Name:\ttessera\nVmPeak:\t  9000 kB\nVmHWM:\t    2048 kB\nVmRSS:\t 1 kB\n";
        assert_eq!(parse_vm_hwm(status), Some(2 * 1024 * 1024));
        assert_eq!(parse_vm_hwm("VmRSS: 1 kB"), None);
        #[cfg(target_os = "linux")]
        assert!(peak_rss_bytes().unwrap() > 0);
    }
}
