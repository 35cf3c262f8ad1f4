//! What the operating system says about memory and open files: every `/proc` read of the
//! program, in one place (Linux; elsewhere each figure is unknown).

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

/// The tightest bound on what this process may still allocate, in bytes, and what sets it:
/// the system's available memory (`MemAvailable`), the cgroup's limit (`memory.max` less
/// `memory.current`, as a container or a batch job sets it) and the address-space limit
/// (`ulimit -v`, less what the process has mapped). `None` where none is known.
pub fn memory_limit() -> Option<(u64, &'static str)> {
    let mut limits = Vec::new();
    if let Some(a) = memory_available() {
        limits.push((a, "available on this machine"));
    }
    if let Some(c) = cgroup_room() {
        limits.push((c, "left under the cgroup's memory limit"));
    }
    if let Some(v) = address_space_room() {
        limits.push((v, "left under the address-space limit (ulimit -v)"));
    }
    limits.into_iter().min_by_key(|(bytes, _)| *bytes)
}

/// The memory this process could allocate at one moment ([`memory_limit`] then): what a
/// piece of work that grows (an import making entities, a parser reading text) checks its
/// whole need against, as it goes. The room left later would count what the work itself
/// already holds twice.
#[derive(Clone, Copy, Debug)]
pub struct Room(Option<(u64, &'static str)>);

impl Room {
    /// The room now.
    pub fn now() -> Room {
        Room(memory_limit())
    }

    /// Refuses `needed` bytes for `what` ("2000 shapes") beyond the room.
    pub fn check(&self, needed: u64, what: &str) -> Result<(), String> {
        match self.0 {
            Some((room, limit)) if needed > room => Err(format!(
                "{what} need about {:.1} GiB of memory; only {:.1} GiB is {limit}",
                needed as f64 / (1u64 << 30) as f64,
                room as f64 / (1u64 << 30) as f64
            )),
            _ => Ok(()),
        }
    }
}

/// The cgroup's memory limit less its usage (cgroup v2, else v1), if it has a limit.
fn cgroup_room() -> Option<u64> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let number = |t: Option<String>| t.and_then(|t| t.trim().parse::<u64>().ok());
    // v2: "0::/path" in /proc/self/cgroup names the group under /sys/fs/cgroup.
    if let Some(path) = read("/proc/self/cgroup").and_then(|t| {
        t.lines()
            .find_map(|l| l.strip_prefix("0::").map(str::to_string))
    }) {
        let dir = format!("/sys/fs/cgroup{}", path.trim_end_matches('/'));
        if let Some(max) = number(read(&format!("{dir}/memory.max"))) {
            let used = number(read(&format!("{dir}/memory.current"))).unwrap_or(0);
            return Some(max.saturating_sub(used));
        }
    }
    // v1: a limit near u64::MAX means none.
    let max = number(read("/sys/fs/cgroup/memory/memory.limit_in_bytes"))?;
    if max >= 1 << 60 {
        return None;
    }
    let used = number(read("/sys/fs/cgroup/memory/memory.usage_in_bytes")).unwrap_or(0);
    Some(max.saturating_sub(used))
}

/// The soft limit named `name` in `/proc/self/limits`, if there is one ("unlimited" is none).
fn soft_limit(name: &str) -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with(name))?;
    line.trim_start_matches(name)
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// How many files this process may have open at once (`ulimit -n`), if it is known.
pub fn open_files_limit() -> Option<u64> {
    soft_limit("Max open files")
}

/// The soft address-space limit less the address space mapped now, if there is a limit.
fn address_space_room() -> Option<u64> {
    let soft = soft_limit("Max address space")?;
    let mapped = proc_kb("/proc/self/status", "VmSize:").unwrap_or(0);
    Some(soft.saturating_sub(mapped))
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
            assert!(open_files_limit().is_some_and(|n| n >= 16));
        }
    }
}
