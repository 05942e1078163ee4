//! Update files on the host (issue 43, `cargo sign-image`): the signing
//! key, made once and kept outside the checkout; a firmware ELF flattened
//! to the bytes a board's flash holds; the file the device takes (image,
//! trailer, signature: `rri_update::image`).

use rri_update::{sign, Trailer, Version, SIGNATURE_LEN, TRAILER_LEN};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The secret key's file name in the key directory (32 bytes: the seed).
pub const SECRET: &str = "update-key";
/// The public key's (32 bytes: what the firmware builds in).
pub const PUBLIC: &str = "update-key.pub";

/// Where the key lives: `$RRI_UPDATE_KEY_DIR`, else
/// `~/.config/rri-sensor`. Never inside the checkout: a key committed by
/// mistake would sign anyone's image.
///
/// Without a `HOME` (or with a relative one) there is no default: the
/// current directory is likely the checkout.
pub fn key_dir() -> Result<PathBuf, String> {
    if let Some(dir) = std::env::var_os("RRI_UPDATE_KEY_DIR") {
        return Ok(PathBuf::from(dir));
    }
    match std::env::var_os("HOME").map(PathBuf::from) {
        Some(home) if home.is_absolute() => Ok(home.join(".config").join("rri-sensor")),
        _ => Err("no absolute HOME: say where the key lives with RRI_UPDATE_KEY_DIR (outside the checkout)".into()),
    }
}

/// Makes a key pair in `dir` (the secret readable by its owner only).
/// Refuses to replace one: every device built with the old public key
/// would refuse every image signed after.
pub fn keygen(dir: &Path) -> Result<(PathBuf, PathBuf), String> {
    let secret = dir.join(SECRET);
    let public = dir.join(PUBLIC);
    if secret.exists() || public.exists() {
        return Err(format!(
            "{} already holds a key: every device built with its public key takes only images it signs; \
             remove it yourself if you mean to replace it",
            dir.display()
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut seed = [0u8; 32];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut seed))
        .map_err(|e| format!("/dev/urandom: {e}"))?;
    // The public key first: a failure then leaves no secret behind that
    // would make every later keygen refuse.
    std::fs::write(&public, sign::public_key(&seed))
        .map_err(|e| format!("{}: {e}", public.display()))?;
    write_private(&secret, &seed)?;
    Ok((secret, public))
}

#[cfg(unix)]
fn write_private(path: &Path, bytes: &[u8]) -> Result<(), String> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)
        .and_then(|mut f| f.write_all(bytes))
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(not(unix))]
fn write_private(path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// A 32-byte key file.
pub fn read_key(path: &Path) -> Result<[u8; 32], String> {
    let bytes = std::fs::read(path).map_err(|e| {
        format!(
            "{}: {e} (make a key pair once with `cargo sign-image -- keygen`)",
            path.display()
        )
    })?;
    bytes
        .try_into()
        .map_err(|b: Vec<u8>| format!("{}: {} bytes, a key is 32", path.display(), b.len()))
}

/// The bytes a firmware ELF puts in flash, from its lowest load address:
/// every loaded segment with file bytes at its physical address (`.data`'s
/// initial values included, where the start-up code copies them from),
/// gaps erased (0xFF). Returns that address and the bytes.
pub fn flat_image(elf: &[u8]) -> Result<(u32, Vec<u8>), String> {
    use object::read::elf::{ElfFile32, ProgramHeader};
    use object::Endianness;
    let file = ElfFile32::<Endianness>::parse(elf).map_err(|e| format!("not a 32-bit ELF: {e}"))?;
    let endian = file.endian();
    let mut parts = Vec::new();
    for ph in file.elf_program_headers() {
        if ph.p_type(endian) != object::elf::PT_LOAD || ph.p_filesz(endian) == 0 {
            continue;
        }
        let data = ph
            .data(endian, elf)
            .map_err(|_| "a segment's bytes lie outside the file".to_string())?;
        parts.push((ph.p_paddr(endian), data));
    }
    let origin = parts
        .iter()
        .map(|p| p.0)
        .min()
        .ok_or("the ELF loads nothing")?;
    let end = parts
        .iter()
        .map(|(at, d)| u64::from(*at) + d.len() as u64)
        .max()
        .unwrap_or(0);
    let len = usize::try_from(end - u64::from(origin)).map_err(|e| e.to_string())?;
    if len > 16 << 20 {
        return Err(format!(
            "the ELF's loaded bytes span {len} bytes from {origin:#010x}: not one flash image"
        ));
    }
    let mut image = vec![0xFF; len];
    for (at, data) in parts {
        let from = (at - origin) as usize;
        image[from..from + data.len()].copy_from_slice(data);
    }
    Ok((origin, image))
}

/// The trailer an update file says it has (read, not checked: the
/// signature is the device's to check).
pub fn trailer_of(file: &[u8]) -> Result<Trailer, String> {
    let raw: [u8; TRAILER_LEN] = file
        .len()
        .checked_sub(TRAILER_LEN + SIGNATURE_LEN)
        .filter(|_| file.len() > TRAILER_LEN + SIGNATURE_LEN)
        .and_then(|at| file.get(at..at + TRAILER_LEN))
        .and_then(|t| t.try_into().ok())
        .ok_or_else(|| {
            format!(
                "{} bytes: too short for an update file (an image, a {TRAILER_LEN}-byte trailer, a {SIGNATURE_LEN}-byte signature)",
                file.len()
            )
        })?;
    Trailer::decode(&raw).map_err(|e| {
        format!("not an update file ({e:?}): make one with `cargo sign-image -- sign`")
    })
}

/// The version a firmware ELF reports (rri-sensor's `RRI_IMAGE_VERSION`
/// symbol: the text, NUL-terminated); `None` for an ELF without it.
pub fn image_version(elf: &[u8]) -> Result<Option<String>, String> {
    use object::{Object, ObjectSection, ObjectSymbol};
    let file = object::File::parse(elf).map_err(|e| format!("not an ELF: {e}"))?;
    let Some(symbol) = file.symbols().find(|s| s.name() == Ok("RRI_IMAGE_VERSION")) else {
        return Ok(None);
    };
    let section = symbol
        .section_index()
        .and_then(|i| file.section_by_index(i).ok())
        .ok_or("the ELF's RRI_IMAGE_VERSION lies in no section")?;
    let data = section.data().map_err(|e| e.to_string())?;
    let from = symbol
        .address()
        .checked_sub(section.address())
        .ok_or("the ELF's RRI_IMAGE_VERSION lies before its section")? as usize;
    let bytes = data
        .get(from..from + symbol.size() as usize)
        .ok_or("the ELF's RRI_IMAGE_VERSION runs past its section")?;
    let text = bytes.split(|&b| b == 0).next().unwrap_or(&[]);
    std::str::from_utf8(text)
        .map(|t| Some(t.to_string()))
        .map_err(|_| "the ELF's RRI_IMAGE_VERSION is not text".to_string())
}

/// rri-sensor's version, from its Cargo.toml (what an image built from
/// this checkout says it is).
pub fn sensor_version() -> Result<String, String> {
    let path = crate::workspace().join("firmware/rri-sensor/Cargo.toml");
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    text.lines()
        .find_map(|l| l.strip_prefix("version = \""))
        .and_then(|l| l.strip_suffix('"'))
        .map(str::to_string)
        .ok_or_else(|| format!("{}: no version line", path.display()))
}

/// The update file of `image`, linked at `origin`, for `board` at
/// `version`, signed with the secret key `seed`.
pub fn signed_file(
    image: &[u8],
    origin: u32,
    board: &str,
    version: Version,
    seed: &[u8; 32],
) -> Result<Vec<u8>, String> {
    let len = u32::try_from(image.len()).map_err(|_| "the image is over 4 GiB".to_string())?;
    let trailer = Trailer::new(board, version, len, origin)
        .ok_or_else(|| format!("{board:?} is no board name (ASCII, 1 to 16 bytes)"))?
        .encode();
    let signature = sign::signature(image, &trailer, seed);
    let mut file = Vec::with_capacity(image.len() + TRAILER_LEN + SIGNATURE_LEN);
    file.extend_from_slice(image);
    file.extend_from_slice(&trailer);
    file.extend_from_slice(&signature);
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal little-endian ELF32 with the given (paddr, bytes)
    /// loaded segments, each at vaddr = paddr + 0x1000_0000 (as `.data`
    /// runs in RAM but is stored in flash).
    fn elf32(segments: &[(u32, &[u8])]) -> Vec<u8> {
        let phoff = 52u32;
        let mut data_off = phoff + 32 * segments.len() as u32;
        let mut out = vec![0u8; 52];
        out[0] = 0x7f;
        out[1..4].copy_from_slice(b"ELF");
        out[4] = 1; // 32-bit
        out[5] = 1; // little-endian
        out[6] = 1; // version
        out[16..18].copy_from_slice(&2u16.to_le_bytes()); // ET_EXEC
        out[18..20].copy_from_slice(&40u16.to_le_bytes()); // EM_ARM
        out[20..24].copy_from_slice(&1u32.to_le_bytes());
        out[28..32].copy_from_slice(&phoff.to_le_bytes());
        out[40..42].copy_from_slice(&52u16.to_le_bytes()); // ehsize
        out[42..44].copy_from_slice(&32u16.to_le_bytes()); // phentsize
        out[44..46].copy_from_slice(&(segments.len() as u16).to_le_bytes());
        out[46..48].copy_from_slice(&40u16.to_le_bytes()); // shentsize
        let mut bodies = Vec::new();
        for (paddr, bytes) in segments {
            let mut ph = [0u8; 32];
            ph[0..4].copy_from_slice(&1u32.to_le_bytes()); // PT_LOAD
            ph[4..8].copy_from_slice(&data_off.to_le_bytes());
            ph[8..12].copy_from_slice(&(paddr + 0x1000_0000).to_le_bytes());
            ph[12..16].copy_from_slice(&paddr.to_le_bytes());
            ph[16..20].copy_from_slice(&(bytes.len() as u32).to_le_bytes());
            ph[20..24].copy_from_slice(&(bytes.len() as u32).to_le_bytes());
            out.extend_from_slice(&ph);
            bodies.extend_from_slice(bytes);
            data_off += bytes.len() as u32;
        }
        out.extend_from_slice(&bodies);
        out
    }

    #[test]
    fn an_elf_flattens_at_its_load_addresses_with_gaps_erased() {
        let elf = elf32(&[(0x0800_0000, &[1, 2, 3, 4]), (0x0800_0008, &[9, 9])]);
        let (origin, image) = flat_image(&elf).unwrap();
        assert_eq!(origin, 0x0800_0000);
        assert_eq!(image, [1, 2, 3, 4, 0xFF, 0xFF, 0xFF, 0xFF, 9, 9]);
        assert!(flat_image(b"not an elf").is_err());
        assert!(flat_image(&elf32(&[(0, &[1]), (0x4000_0000, &[2])])).is_err());
    }

    #[test]
    fn a_key_is_made_once_and_signs_a_file_the_device_would_check() {
        let dir = std::env::temp_dir().join(format!("rri-key-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (secret, public) = keygen(&dir).unwrap();
        assert!(keygen(&dir).unwrap_err().contains("already holds a key"));
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&secret).unwrap().permissions().mode();
            assert_eq!(mode & 0o077, 0, "the secret key is its owner's alone");
        }
        let seed = read_key(&secret).unwrap();
        assert_eq!(read_key(&public).unwrap(), sign::public_key(&seed));
        let version = Version::parse("1.2.3").unwrap();
        let file = signed_file(&[0xAB; 100], 0x0808_0000, "nucleo-f767zi", version, &seed).unwrap();
        assert_eq!(file.len(), 100 + TRAILER_LEN + SIGNATURE_LEN);
        let trailer: [u8; TRAILER_LEN] = file[100..164].try_into().unwrap();
        let t = Trailer::decode(&trailer).unwrap();
        assert_eq!(
            (t.board_name(), t.version, t.image_len, t.origin),
            ("nucleo-f767zi", version, 100, 0x0808_0000)
        );
        assert!(signed_file(&[0; 4], 0, "", version, &seed).is_err());
        // And the device's own check takes it (the flash model's update
        // partition, the key read back from its file).
        use crate::flash_model::{Flash, Power};
        let power = Power::new();
        let mut dfu = Flash::<2048, 32>::erased(4096, &power);
        let mut state = Flash::<2048, 32>::erased(2048, &power);
        let config = rri_update::FirmwareUpdaterConfig {
            dfu: &mut dfu,
            state: &mut state,
        };
        let mut up = rri_update::Upload::begin(config, 2048, file.len()).unwrap();
        up.push(&file).unwrap();
        let running = rri_update::Running {
            board: "nucleo-f767zi",
            origin: 0x0808_0000,
            version: Version::parse("1.0.0").unwrap(),
        };
        assert_eq!(
            up.finish(&running, &read_key(&public).unwrap(), false),
            Ok(t)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
