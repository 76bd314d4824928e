//! How much more memory this process may take: input, the files Linux
//! keeps under `/proc` and `/sys/fs/cgroup`, and a trial reservation;
//! output, a byte count and what limits it, or nothing where no file says
//! (another system, or none of them readable). A render's pixels are
//! checked against it before any work starts, so that a limit (`ulimit
//! -v`, a batch job's memory, a small machine) gives a message rather
//! than an allocation failure that aborts the process.

/// The most bytes this process may still allocate, and what sets that.
pub fn available() -> Option<(u64, &'static str)> {
    let mut best: Option<(u64, &'static str)> = None;
    let mut consider = |bytes: Option<u64>, what: &'static str| {
        if let Some(b) = bytes {
            if best.is_none_or(|(least, _)| b < least) {
                best = Some((b, what));
            }
        }
    };
    consider(mem_available(), "the machine's available memory");
    consider(
        cgroup_left(),
        "the memory limit of this job's control group",
    );
    best
}

/// Whether `bytes` can be reserved now (and they are released at once):
/// under an address-space limit (`ulimit -v`) what counts is whether the
/// allocation itself succeeds, not what the process has mapped (the
/// compile thread's stack reserves 512 MB it mostly never touches). With
/// the usual overcommit this touches no memory.
pub fn can_reserve(bytes: u64) -> bool {
    let Ok(bytes) = usize::try_from(bytes) else {
        return false;
    };
    Vec::<u8>::new().try_reserve_exact(bytes).is_ok()
}

/// `MemAvailable` of `/proc/meminfo`.
fn mem_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    kilobytes_after(&text, "MemAvailable:")
}

/// A cgroup v2 limit (`memory.max`) less the group's use.
fn cgroup_left() -> Option<u64> {
    let read = |name: &str| std::fs::read_to_string(format!("/sys/fs/cgroup/{name}")).ok();
    let max: u64 = read("memory.max")?.trim().parse().ok()?; // "max": none.
    let current: u64 = read("memory.current")?.trim().parse().ok()?;
    Some(max.saturating_sub(current))
}

/// The number after `key` on its line of `text`, in kB, as bytes.
fn kilobytes_after(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line[key.len()..].split_whitespace().next()?.parse().ok()?;
    kb.checked_mul(1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_kilobytes_from_proc_style_text() {
        let text = "MemTotal:       24683724 kB\nMemAvailable:   24315600 kB\n";
        assert_eq!(
            kilobytes_after(text, "MemAvailable:"),
            Some(24_315_600 * 1024)
        );
        assert_eq!(kilobytes_after(text, "SwapTotal:"), None);
    }
}
