//! The machine a report was made on, read from the OS (Linux `/proc`; elsewhere what the
//! standard library knows).

use serde::Serialize;

/// Facts about the machine and build.
#[derive(Clone, Debug, Serialize)]
pub struct MachineInfo {
    /// CPU model name.
    pub cpu: String,
    /// Threads the work ran on (rayon's pool).
    pub threads: usize,
    /// Total memory, GiB (0 when unknown).
    pub memory_gib: f64,
    /// Operating system and architecture.
    pub os: String,
    /// Lucid's version.
    pub lucid: String,
    /// burn's backend for training.
    pub backend: String,
}

impl MachineInfo {
    /// Reads the facts.
    pub fn read() -> Self {
        let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let cpu = cpuinfo
            .lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().to_string())
            .unwrap_or_else(|| "unknown".into());
        let memory_gib = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|m| {
                m.lines()
                    .find(|l| l.starts_with("MemTotal:"))
                    .and_then(|l| l.split_whitespace().nth(1).and_then(|v| v.parse::<f64>().ok()))
            })
            .map(|kib| kib / (1024.0 * 1024.0))
            .unwrap_or(0.0);
        Self {
            cpu,
            threads: rayon::current_num_threads(),
            memory_gib,
            os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
            lucid: env!("CARGO_PKG_VERSION").into(),
            backend: lucid_burn::backend::backend_name().into(),
        }
    }

    /// As table rows.
    pub fn rows(&self) -> Vec<Vec<String>> {
        vec![
            vec!["CPU".into(), self.cpu.clone()],
            vec!["threads".into(), self.threads.to_string()],
            vec!["memory".into(), format!("{:.1} GiB", self.memory_gib)],
            vec!["OS".into(), self.os.clone()],
            vec!["Lucid".into(), self.lucid.clone()],
            vec!["burn backend".into(), self.backend.clone()],
        ]
    }
}
