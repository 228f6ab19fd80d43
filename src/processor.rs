//! The processor features the build assumes (`.cargo/config.toml` builds for x86-64-v3):
//! checked first thing, so that a processor without them gets a message rather than an
//! illegal instruction somewhere in a run.

/// A feature of x86-64-v3, whether the build was compiled to assume it, and how the
/// processor says it has it: a CPUID leaf and sub-leaf, the register (`b`: EBX, `c`: ECX),
/// and the bit.
#[cfg(target_arch = "x86_64")]
struct Feature {
    name: &'static str,
    assumed: bool,
    leaf: (u32, u32),
    reg: char,
    bit: u32,
}

#[cfg(target_arch = "x86_64")]
const fn feature(
    name: &'static str,
    assumed: bool,
    leaf: (u32, u32),
    reg: char,
    bit: u32,
) -> Feature {
    Feature {
        name,
        assumed,
        leaf,
        reg,
        bit,
    }
}

/// The features of x86-64-v3 beyond the baseline that the code may use.
#[cfg(target_arch = "x86_64")]
const FEATURES: [Feature; 9] = [
    feature("sse4.2", cfg!(target_feature = "sse4.2"), (1, 0), 'c', 20),
    feature("popcnt", cfg!(target_feature = "popcnt"), (1, 0), 'c', 23),
    feature("avx", cfg!(target_feature = "avx"), (1, 0), 'c', 28),
    feature("fma", cfg!(target_feature = "fma"), (1, 0), 'c', 12),
    feature("movbe", cfg!(target_feature = "movbe"), (1, 0), 'c', 22),
    feature("avx2", cfg!(target_feature = "avx2"), (7, 0), 'b', 5),
    feature("bmi1", cfg!(target_feature = "bmi1"), (7, 0), 'b', 3),
    feature("bmi2", cfg!(target_feature = "bmi2"), (7, 0), 'b', 8),
    feature(
        "lzcnt",
        cfg!(target_feature = "lzcnt"),
        (0x8000_0001, 0),
        'c',
        5,
    ),
];

/// What to tell the user when this processor (or its operating system, for the AVX
/// registers) lacks a feature the build assumes; `None` when it lacks none. The command
/// line and the Python package call this first.
pub fn check() -> Option<String> {
    refusal(&missing())
}

/// The features the build assumes that this processor (or its operating system, for the
/// AVX registers) lacks: none on other architectures, or for a build that assumes none.
fn missing() -> Vec<&'static str> {
    #[cfg(target_arch = "x86_64")]
    {
        missing_of(cpu_has)
    }
    #[cfg(not(target_arch = "x86_64"))]
    Vec::new()
}

/// [`missing`], the processor's answers given by `has`: each feature assumed that it
/// lacks.
#[cfg(target_arch = "x86_64")]
fn missing_of(has: impl Fn(&Feature) -> bool) -> Vec<&'static str> {
    (FEATURES.iter())
        .filter(|f| f.assumed && !has(f))
        .map(|f| f.name)
        .collect()
}

/// Whether CPUID says the processor has feature `f`; the AVX features also need the
/// operating system to keep the AVX registers.
#[cfg(target_arch = "x86_64")]
fn cpu_has(f: &Feature) -> bool {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    // (A leaf beyond the highest answers zeros or the highest's values: the highest is
    // asked first.)
    let top = __cpuid(f.leaf.0 & 0x8000_0000).eax;
    if f.leaf.0 > top {
        return false;
    }
    let r = __cpuid_count(f.leaf.0, f.leaf.1);
    let word = if f.reg == 'b' { r.ebx } else { r.ecx };
    word >> f.bit & 1 == 1 && (!f.name.starts_with("avx") || os_keeps_avx())
}

/// Whether the operating system saves the AVX registers (OSXSAVE set, and XCR0 with the
/// SSE and AVX state).
#[cfg(target_arch = "x86_64")]
fn os_keeps_avx() -> bool {
    use std::arch::x86_64::__cpuid;
    let osxsave = __cpuid(1).ecx >> 27 & 1 == 1;
    if !osxsave {
        return false;
    }
    let (lo, _hi): (u32, u32);
    // SAFETY: XGETBV 0 is allowed when OSXSAVE is set (checked above).
    unsafe {
        std::arch::asm!("xgetbv", in("ecx") 0u32, out("eax") lo, out("edx") _hi, options(nomem, nostack));
    }
    lo & 0b110 == 0b110
}

/// The message for a processor that lacks the features `missing` (None when it lacks
/// none).
fn refusal(missing: &[&str]) -> Option<String> {
    (!missing.is_empty()).then(|| {
        format!(
            "this build of latticesim needs an x86-64-v3 processor, and this one lacks {}; \
             build it for this one with RUSTFLAGS=\"-C target-cpu=native\" cargo build --release \
             (see docs/running.md, Processors)",
            missing.join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn this_processor_runs_this_build() {
        // (Else no test of this build could run here.)
        assert_eq!(super::missing(), Vec::<&str>::new());
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn a_processor_without_a_feature_assumed_is_named_it() {
        let lacking_avx2 = super::missing_of(|f| (f.leaf, f.reg, f.bit) != ((7, 0), 'b', 5));
        let assumed = cfg!(target_feature = "avx2");
        assert_eq!(lacking_avx2, if assumed { vec!["avx2"] } else { vec![] });
        let none = super::missing_of(|_| false);
        let count = super::FEATURES.iter().filter(|f| f.assumed).count();
        assert_eq!(none.len(), count);
        let text = super::refusal(&["avx2", "bmi2"]).expect("a message");
        assert!(
            text.contains("lacks avx2, bmi2") && text.contains("target-cpu=native"),
            "{text}"
        );
        assert_eq!(super::refusal(&[]), None);
    }

    /// docs/running.md shows the message as the command line prints it.
    #[test]
    fn the_docs_show_the_message() {
        let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/running.md"))
            .expect("docs/running.md");
        let text = super::refusal(&["avx2", "bmi2"]).expect("a message");
        assert!(doc.contains(&format!("latticesim: {text}\n")), "{text}");
    }
}
