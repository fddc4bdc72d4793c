//! How much more memory this process may take: the least of the system's
//! available memory, its memory cgroup's room and its address-space limit.
//! Here, beside the device, because a CPU device's memory is host memory,
//! and because the address-space limit is read with `getrlimit` (unsafe:
//! this layer holds vkrad's only `unsafe`).
//!
//! Every source is parsed from its text by a pure function, so the parsing
//! is tested on fixed text; [`HostMemory::now`] reads the live files.

use std::path::Path;

/// What was read of each limit, in bytes; `None` where the system does not
/// say or sets no limit.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HostMemory {
    /// `MemAvailable` in /proc/meminfo.
    pub available: Option<u64>,
    /// The memory cgroup's room: its limit less its use, the least over
    /// the process's cgroup and its ancestors (v2 `memory.max` less
    /// `memory.current`, v1 `memory.limit_in_bytes` less
    /// `memory.usage_in_bytes`).
    pub cgroup_room: Option<u64>,
    /// `RLIMIT_AS` (`ulimit -v`), and the address space the process
    /// already maps (`VmSize` in /proc/self/status).
    pub address_limit: Option<u64>,
    pub address_used: Option<u64>,
}

/// Which limit binds (for the messages that name the setting to change).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Binding {
    Available,
    Cgroup,
    AddressSpace,
}

impl Binding {
    /// How a message names it.
    pub fn describe(self) -> &'static str {
        match self {
            Binding::Available => "memory available",
            Binding::Cgroup => "memory left to this process's cgroup",
            Binding::AddressSpace => "address space left under the process's limit (ulimit -v)",
        }
    }
}

/// Limits at or above this are "no limit" (cgroup v1 writes 2^63 rounded
/// down to a page; `RLIM_INFINITY` is 2^64 - 1).
const UNLIMITED: u64 = 1 << 60;

impl HostMemory {
    /// The limits as they are now; all `None` off Linux.
    pub fn now() -> Self {
        let read = |p: &str| std::fs::read_to_string(p).ok();
        let status = read("/proc/self/status");
        HostMemory {
            available: read("/proc/meminfo").and_then(|t| parse_kib_field(&t, "MemAvailable:")),
            cgroup_room: read("/proc/self/cgroup")
                .and_then(|t| cgroup_room(&t, Path::new("/sys/fs/cgroup"), &|p| read_path(p))),
            address_limit: address_space_limit(),
            address_used: status.and_then(|t| parse_kib_field(&t, "VmSize:")),
        }
    }

    /// The address space left under `RLIMIT_AS`, less a margin: the limit
    /// counts mappings, not resident pages, and allocator arenas, thread
    /// stacks and the driver's reservations grow beside what the estimate
    /// counts. Without `VmSize`, half the limit is taken as used.
    pub fn address_room(&self) -> Option<u64> {
        let limit = self.address_limit.filter(|&l| l < UNLIMITED)?;
        let used = self.address_used.unwrap_or(limit / 2);
        let room = limit.saturating_sub(used);
        Some(room - (room / 8).max(128 << 20).min(room))
    }

    /// The memory this process may still take, and the limit that binds;
    /// `None` where the system says nothing.
    pub fn room(&self) -> Option<(u64, Binding)> {
        [
            (self.available, Binding::Available),
            (self.cgroup_room, Binding::Cgroup),
            (self.address_room(), Binding::AddressSpace),
        ]
        .into_iter()
        .filter_map(|(b, why)| b.map(|b| (b, why)))
        .min_by_key(|&(b, _)| b)
    }
}

fn read_path(p: &Path) -> Option<String> {
    std::fs::read_to_string(p).ok()
}

/// The address-space limit (`RLIMIT_AS`, soft), `None` when unlimited.
#[cfg(unix)]
#[allow(clippy::unnecessary_cast)] // `rlim_t` is u64 on Linux, not on every unix
fn address_space_limit() -> Option<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes one `rlimit` through a valid pointer.
    let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } == 0;
    (ok && limit.rlim_cur != libc::RLIM_INFINITY).then_some(limit.rlim_cur as u64)
}

#[cfg(not(unix))]
fn address_space_limit() -> Option<u64> {
    None
}

/// A `Name:   N kB` line of /proc/meminfo or /proc/self/status, in bytes.
pub fn parse_kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// The room left in the memory cgroup that /proc/self/cgroup's `text` names,
/// under the hierarchy mounted at `root`, with `read` reading its files:
/// the least of limit less use over the cgroup and its ancestors (a parent's
/// limit binds its children). `None` when no level sets a limit.
pub fn cgroup_room(text: &str, root: &Path, read: &dyn Fn(&Path) -> Option<String>) -> Option<u64> {
    let number = |p: &Path| -> Option<u64> { read(p)?.trim().parse().ok() };
    let mut least: Option<u64> = None;
    let mut take = |limit: Option<u64>, used: Option<u64>| {
        if let Some(limit) = limit.filter(|&l| l < UNLIMITED) {
            let room = limit.saturating_sub(used.unwrap_or(0));
            least = Some(least.map_or(room, |l| l.min(room)));
        }
    };
    for line in text.lines() {
        // "hierarchy-id:controllers:path"; v2 is "0::path".
        let mut fields = line.splitn(3, ':');
        let (Some(id), Some(controllers), Some(path)) =
            (fields.next(), fields.next(), fields.next())
        else {
            continue;
        };
        let (dir, limit_file, used_file) = if id == "0" && controllers.is_empty() {
            (root.to_path_buf(), "memory.max", "memory.current")
        } else if controllers.split(',').any(|c| c == "memory") {
            (
                root.join("memory"),
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
            )
        } else {
            continue;
        };
        // The cgroup and each ancestor up to the hierarchy's root; inside a
        // container the hierarchy's root may itself be the cgroup.
        let mut level = Path::new(path.trim_start_matches('/'));
        loop {
            let here = dir.join(level);
            // v2's "max" parses as no number: no limit at this level.
            take(
                number(&here.join(limit_file)),
                number(&here.join(used_file)),
            );
            match level.parent() {
                Some(up) => level = up,
                None => break,
            }
        }
    }
    least
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    const STATUS: &str =
        "Name:\tvkrad\nVmPeak:\t 1245916 kB\nVmSize:\t  986276 kB\nVmHWM:\t  493460 kB\n";
    const MEMINFO: &str =
        "MemTotal:       24567244 kB\nMemFree:        12000000 kB\nMemAvailable:   23000000 kB\n";

    fn files(list: &[(&str, &str)]) -> impl Fn(&Path) -> Option<String> {
        let map: HashMap<String, String> = list
            .iter()
            .map(|(p, t)| (p.to_string(), t.to_string()))
            .collect();
        move |p: &Path| map.get(p.to_str()?).cloned()
    }

    #[test]
    fn kib_fields_are_read_as_bytes() {
        assert_eq!(parse_kib_field(STATUS, "VmSize:"), Some(986_276 * 1024));
        assert_eq!(parse_kib_field(STATUS, "VmHWM:"), Some(493_460 * 1024));
        assert_eq!(
            parse_kib_field(MEMINFO, "MemAvailable:"),
            Some(23_000_000 * 1024)
        );
        assert_eq!(parse_kib_field(MEMINFO, "Cached:"), None);
        assert_eq!(parse_kib_field("VmSize: lots kB", "VmSize:"), None);
    }

    #[test]
    fn cgroup_v2_room_is_the_least_over_the_cgroup_and_its_ancestors() {
        let read = files(&[
            ("/cg/user.slice/memory.max", "8589934592\n"),
            ("/cg/user.slice/memory.current", "1073741824\n"),
            ("/cg/user.slice/run.scope/memory.max", "max\n"),
            ("/cg/user.slice/run.scope/memory.current", "104857600\n"),
        ]);
        let room = cgroup_room("0::/user.slice/run.scope\n", Path::new("/cg"), &read);
        assert_eq!(room, Some((8 << 30) - (1 << 30)));
        // The cgroup's own limit binds when it is the smaller.
        let read = files(&[
            ("/cg/a/memory.max", "8589934592"),
            ("/cg/a/memory.current", "0"),
            ("/cg/a/b/memory.max", "2147483648"),
            ("/cg/a/b/memory.current", "536870912"),
        ]);
        assert_eq!(
            cgroup_room("0::/a/b", Path::new("/cg"), &read),
            Some(3 << 29)
        );
        // No limit anywhere: nothing to say.
        let read = files(&[("/cg/memory.max", "max")]);
        assert_eq!(cgroup_room("0::/", Path::new("/cg"), &read), None);
    }

    #[test]
    fn cgroup_v1_reads_the_memory_controller_s_hierarchy() {
        let text = "9:name=systemd:/\n4:memory:/process_api/1bb1\n1:cpu:/\n";
        let read = files(&[
            // The namespaced root (inside a container) and the full path.
            ("/cg/memory/memory.limit_in_bytes", "9223372036854771712\n"),
            ("/cg/memory/memory.usage_in_bytes", "2340823040\n"),
            (
                "/cg/memory/process_api/1bb1/memory.limit_in_bytes",
                "4294967296\n",
            ),
            (
                "/cg/memory/process_api/1bb1/memory.usage_in_bytes",
                "1073741824\n",
            ),
        ]);
        assert_eq!(
            cgroup_room(text, Path::new("/cg"), &read),
            Some(3 << 30),
            "the unlimited root does not count"
        );
        assert_eq!(cgroup_room("1:cpu:/\n", Path::new("/cg"), &read), None);
    }

    #[test]
    fn the_address_limit_leaves_a_margin_over_what_is_mapped() {
        let h = HostMemory {
            available: Some(20 << 30),
            cgroup_room: None,
            address_limit: Some(4 << 30),
            address_used: Some(1 << 30),
        };
        let room = h.address_room().unwrap();
        assert_eq!(room, (3 << 30) - (3 << 30) / 8);
        assert_eq!(h.room(), Some((room, Binding::AddressSpace)));
        // Unlimited, or nothing read: the available memory binds.
        let free = HostMemory {
            address_limit: None,
            ..h
        };
        assert_eq!(free.room(), Some((20 << 30, Binding::Available)));
        assert_eq!(HostMemory::default().room(), None);
        // Already over the limit: no room, not an underflow.
        let over = HostMemory {
            address_used: Some(5 << 30),
            ..h
        };
        assert_eq!(over.address_room(), Some(0));
        // The live reading works where there is a /proc.
        if Path::new("/proc/self/status").exists() {
            assert!(HostMemory::now().address_used.is_some());
        }
    }
}
