//! The CPU a figure was measured on: its model name, with the family and
//! model numbers that tell CPU generations apart where a virtual machine
//! gives them all one name ("AMD EPYC"), and the SIMD extensions it has.
//! `firn bench` prints it before timing and stores it in every record;
//! `firn info` prints it. Read from three lines of `/proc/cpuinfo` (Linux)
//! and the standard library's feature detection: a CPUID crate
//! (`raw-cpuid`) would give the same numbers on x86 only, for a dependency.

use serde::Serialize;

/// The CPU this process runs on.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Cpu {
    /// The model name, or "unknown" where the system does not say.
    pub model: String,
    /// The x86 family number, where known.
    pub family: Option<u32>,
    /// The x86 model number within the family, where known.
    pub model_number: Option<u32>,
    /// The SIMD extensions firn's paths use, or that tell their speed, that
    /// the CPU has.
    pub simd_flags: Vec<&'static str>,
}

impl Cpu {
    /// The CPU this process runs on.
    pub fn detect() -> Cpu {
        let text = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let (model, family, model_number) = parse_cpuinfo(&text);
        Cpu {
            model,
            family,
            model_number,
            simd_flags: simd_flags(),
        }
    }

    /// One line: the model, its family and model numbers, the SIMD flags.
    pub fn describe(&self) -> String {
        let numbers = match (self.family, self.model_number) {
            (Some(family), Some(model)) => format!(" (family {family}, model {model})"),
            _ => String::new(),
        };
        let flags = if self.simd_flags.is_empty() {
            "none of avx, avx2, fma, avx-512".to_string()
        } else {
            self.simd_flags.join(" ")
        };
        format!("{}{numbers}; SIMD {flags}", self.model)
    }
}

/// The model name and the family and model numbers of the first processor
/// listed in `/proc/cpuinfo`'s text.
fn parse_cpuinfo(text: &str) -> (String, Option<u32>, Option<u32>) {
    let first = text.split("\n\n").next().unwrap_or_default();
    let field = |name: &str| {
        first.lines().find_map(|line| {
            let (key, value) = line.split_once(':')?;
            (key.trim() == name).then(|| value.trim().to_string())
        })
    };
    let number = |name: &str| field(name).and_then(|value| value.parse().ok());
    let model = field("model name").unwrap_or_else(|| "unknown".into());
    (model, number("cpu family"), number("model"))
}

/// The SIMD extensions of the running CPU among those that matter here.
fn simd_flags() -> Vec<&'static str> {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        [
            ("sse4.1", has!("sse4.1")),
            ("avx", has!("avx")),
            ("avx2", has!("avx2")),
            ("fma", has!("fma")),
            ("avx512f", has!("avx512f")),
            ("avx512dq", has!("avx512dq")),
            ("avx512bw", has!("avx512bw")),
            ("avx512vl", has!("avx512vl")),
        ]
        .into_iter()
        .filter_map(|(name, present)| present.then_some(name))
        .collect()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_processor_gives_the_name_and_numbers() {
        let text = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 23\n\
                    model\t\t: 1\nmodel name\t: AMD EPYC\nflags\t\t: fpu avx2\n\n\
                    processor\t: 1\ncpu family\t: 25\nmodel\t\t: 17\nmodel name\t: other\n";
        assert_eq!(
            parse_cpuinfo(text),
            ("AMD EPYC".to_string(), Some(23), Some(1))
        );
        assert_eq!(parse_cpuinfo(""), ("unknown".to_string(), None, None));
        let cpu = Cpu {
            model: "AMD EPYC".into(),
            family: Some(23),
            model_number: Some(1),
            simd_flags: vec!["avx2", "fma"],
        };
        assert_eq!(
            cpu.describe(),
            "AMD EPYC (family 23, model 1); SIMD avx2 fma"
        );
    }
}
