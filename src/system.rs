//! What the operating system says about memory: every `/proc` read of the program, in one
//! place (Linux; elsewhere each figure is unknown).

/// A figure in kB of the `key:` line of a `/proc` file, in bytes.
fn proc_kb(file: &str, key: &str) -> Option<u64> {
    std::fs::read_to_string(file).ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    })
}

/// Memory available for new allocations now (`MemAvailable`), in bytes.
pub fn memory_available() -> Option<u64> {
    proc_kb("/proc/meminfo", "MemAvailable:")
}

/// Peak resident memory of this process, in bytes (0 where unknown).
pub fn peak_rss() -> u64 {
    proc_kb("/proc/self/status", "VmHWM:").unwrap_or(0)
}

/// Resident memory of this process now, in bytes (0 where unknown).
pub fn resident_bytes() -> u64 {
    proc_kb("/proc/self/status", "VmRSS:").unwrap_or(0)
}

/// Resets the peak resident memory to the current one (Linux's `clear_refs` 5), so that a
/// later [`peak_rss`] tells the peak of what ran in between. False where that is not possible.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linux_reports_memory_figures() {
        if cfg!(target_os = "linux") {
            let available = memory_available().expect("MemAvailable");
            assert!(available > 1 << 20);
            assert!(resident_bytes() > 0 && peak_rss() >= resident_bytes());
        }
    }
}
