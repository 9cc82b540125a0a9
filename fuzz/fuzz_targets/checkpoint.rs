//! Checkpoints: any bytes are either a checkpoint or an error. The input is
//! read twice, as it is and with its trailing CRC-32 made to match, so that
//! mutations reach the parser behind the checksum.
#![no_main]

use std::path::Path;

use firn_io::Checkpoint;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.firnckpt");
    let _ = Checkpoint::from_bytes(data, path);
    if data.len() >= 4 {
        let mut fixed = data.to_vec();
        let body = fixed.len() - 4;
        let checksum = crc32fast::hash(&fixed[..body]);
        fixed[body..].copy_from_slice(&checksum.to_le_bytes());
        if let Ok(checkpoint) = Checkpoint::from_bytes(&fixed, path) {
            for (name, _) in &checkpoint.arrays {
                let _ = checkpoint.array::<f32>(name);
                let _ = checkpoint.array::<[f32; 9]>(name);
                let _ = checkpoint.array::<u16>(name);
            }
        }
    }
});
