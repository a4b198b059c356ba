//! The process's peak resident memory (`peak_rss_bytes` in `build --json` and
//! `gen mesh --json`): VmHWM from /proc/self/status on Linux, `None` elsewhere.

/// Peak resident set size in bytes, where the system says.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_vm_hwm(&status)
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
