//! The GUID (FMI 2.0) / instantiation token (FMI 3.0) of an FMU: a 128-bit hash of the FMU
//! flavour (`fmi2-plant`, `fmi3-controller`, ...), the binary's version and the model file's
//! text, formatted as a UUID (version 8, "vendor-defined"). It changes whenever the model's
//! content or the FMU binary's version changes, and the FMU checks it at instantiation.
//!
//! Self-contained on purpose: the FMI 3.0 build scripts include this file with `#[path]`.

/// Bump when the variable layout or stepping semantics change without a version change.
pub const INTERFACE_REVISION: &str = "1";

/// The version of the FMU binary that goes into the hash.
pub fn binary_version() -> String {
    format!("{}+r{}", env!("CARGO_PKG_VERSION"), INTERFACE_REVISION)
}

fn fnv1a64(offset: u64, parts: &[&[u8]]) -> u64 {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut h = offset;
    for part in parts {
        for &b in part.iter() {
            h ^= u64::from(b);
            h = h.wrapping_mul(PRIME);
        }
        // Separator: "ab" + "c" and "a" + "bc" hash differently.
        h ^= 0xff;
        h = h.wrapping_mul(PRIME);
    }
    h
}

/// The GUID of the FMU of flavour `flavour` built from the model file text `model_toml`.
pub fn guid(flavour: &str, model_toml: &str) -> String {
    let version = binary_version();
    let parts: [&[u8]; 4] = [
        b"zmp-fmu",
        flavour.as_bytes(),
        version.as_bytes(),
        model_toml.as_bytes(),
    ];
    let hi = fnv1a64(0xcbf2_9ce4_8422_2325, &parts);
    let lo = fnv1a64(0x6c62_272e_07bb_0142, &parts);
    let mut b = [0u8; 16];
    b[..8].copy_from_slice(&hi.to_be_bytes());
    b[8..].copy_from_slice(&lo.to_be_bytes());
    b[6] = (b[6] & 0x0f) | 0x80; // version 8
    b[8] = (b[8] & 0x3f) | 0x80; // RFC 4122 variant
    let hex: String = b.iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}
