//! What a training configuration will allocate, estimated before anything is allocated, and a
//! refusal that names the keys responsible when it cannot fit: an in-range setting such as a
//! 2²⁶-entry hash table would otherwise take the machine's memory within seconds and end in
//! the kernel's out-of-memory killer (or swap), not in an error.

/// One GiB.
const GIB: f64 = (1u64 << 30) as f64;

/// Memory the process needs beyond what a configuration drives: the binary, the runtime, the
/// allocator's slack and burn's own buffers.
pub const BASE_BYTES: u64 = 300 << 20;

/// The environment variable that sets the memory Lucid may use (`8G`, `512M`, or bytes), in
/// place of what the machine reports available: for shared machines, and for tests.
pub const LIMIT_VARIABLE: &str = "LUCID_MEMORY_LIMIT";

/// A configuration's expected peak memory, part by part.
#[derive(Clone, Debug, Default)]
pub struct MemoryEstimate {
    parts: Vec<(String, u64)>,
}

impl MemoryEstimate {
    /// An estimate holding only [`BASE_BYTES`].
    pub fn new() -> Self {
        Self { parts: vec![("the program itself".into(), BASE_BYTES)] }
    }

    /// Adds a part: `what` names it with the keys that drive it (`hash table
    /// (field.grid.log2_table_size = 26, …)`).
    pub fn add(&mut self, what: impl Into<String>, bytes: f64) {
        self.parts.push((what.into(), bytes.max(0.0).min(u64::MAX as f64) as u64));
    }

    /// The parts, largest first.
    pub fn parts(&self) -> Vec<(String, u64)> {
        let mut parts = self.parts.clone();
        parts.sort_by_key(|p| std::cmp::Reverse(p.1));
        parts
    }

    /// Total bytes.
    pub fn total(&self) -> u64 {
        self.parts.iter().map(|p| p.1).fold(0, u64::saturating_add)
    }

    /// Refuses the configuration if it needs more than `available` bytes, naming its largest
    /// parts.
    pub fn check(&self, available: Option<Available>) -> Result<(), String> {
        let Some(available) = available else { return Ok(()) };
        let total = self.total();
        if total <= available.bytes {
            return Ok(());
        }
        let parts: Vec<String> = self
            .parts()
            .into_iter()
            .take(3)
            .map(|(what, bytes)| format!("{what}: {:.2} GiB", bytes as f64 / GIB))
            .collect();
        Err(format!(
            "this configuration needs about {:.2} GiB ({}), but {:.2} GiB is available ({}); lower the keys named",
            total as f64 / GIB,
            parts.join("; "),
            available.bytes as f64 / GIB,
            available.source
        ))
    }
}

/// Memory the process may use, and where that figure comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct Available {
    /// Bytes.
    pub bytes: u64,
    /// "reported by the system", "the cgroup's limit", or the variable.
    pub source: String,
}

/// Parses `8G`, `512M`, `64K` or a plain byte count.
pub fn parse_size(text: &str) -> Option<u64> {
    let t = text.trim();
    let (digits, scale) = match t.char_indices().last()? {
        (i, 'G' | 'g') => (&t[..i], 1u64 << 30),
        (i, 'M' | 'm') => (&t[..i], 1 << 20),
        (i, 'K' | 'k') => (&t[..i], 1 << 10),
        _ => (t, 1),
    };
    let value: f64 = digits.trim().parse().ok()?;
    (value.is_finite() && value >= 0.0).then_some((value * scale as f64) as u64)
}

/// The memory this process may use: [`LIMIT_VARIABLE`] if set, else the smaller of what the
/// system reports available and what its cgroup (a container's limit) leaves free; `None`
/// where neither can be read (then nothing is refused).
pub fn available() -> Result<Option<Available>, String> {
    if let Ok(text) = std::env::var(LIMIT_VARIABLE) {
        let bytes = parse_size(&text)
            .ok_or_else(|| format!("{LIMIT_VARIABLE}={text:?}: expected a size such as 8G, 512M or a byte count"))?;
        return Ok(Some(Available { bytes, source: format!("{LIMIT_VARIABLE}={text}") }));
    }
    let mut system = sysinfo::System::new();
    system.refresh_memory();
    let reported = system.available_memory();
    let cgroup = system.cgroup_limits().map(|c| c.free_memory).filter(|&b| b > 0);
    Ok(match (reported, cgroup) {
        (0, None) => None,
        (r, Some(c)) if c < r || r == 0 => Some(Available { bytes: c, source: "the cgroup's free memory".into() }),
        (r, _) => Some(Available { bytes: r, source: "reported available by the system".into() }),
    })
}

/// Bytes of `count` values of 4 bytes each.
pub fn floats(count: f64) -> f64 {
    4.0 * count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_estimates_refuse_naming_their_largest_part() {
        assert_eq!(parse_size("8G"), Some(8 << 30));
        assert_eq!(parse_size("1.5m"), Some(3 << 19));
        assert_eq!(parse_size("4096"), Some(4096));
        assert_eq!(parse_size("lots"), None);
        assert_eq!(parse_size("-1G"), None);
        let mut e = MemoryEstimate::new();
        e.add("hash table (field.grid.log2_table_size = 26)", 8.0 * GIB);
        e.add("images", 0.5 * GIB);
        assert!(e.check(None).is_ok());
        let fits = Available { bytes: 9 << 30, source: "test".into() };
        assert!(e.check(Some(fits)).is_ok());
        let err = e.check(Some(Available { bytes: 4 << 30, source: "test".into() })).unwrap_err();
        assert!(err.starts_with("this configuration needs about 8.79 GiB (hash table"), "{err}");
        assert!(err.contains("log2_table_size = 26): 8.00 GiB") && err.contains("4.00 GiB is available"), "{err}");
    }
}
