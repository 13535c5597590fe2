//! A check of an OpenEXR file's headers in safe Rust before OpenEXR reads it: the `openexr` crate
//! panics on a channel name that is not UTF-8 (a damaged byte of the channel list), so the
//! channel lists are read here first and such a file is an error naming it.

/// The largest header read (attributes and channel lists; a header is rarely over a few KiB).
pub(super) const MAX_HEADER_BYTES: usize = 16 << 20;

/// Check the headers at the start of an EXR file (`bytes`: its first bytes, up to
/// [`MAX_HEADER_BYTES`]): the magic number, attributes that fit in the file, and channel names
/// that are non-empty UTF-8. `Err` says what is wrong.
pub(super) fn check(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < 8 || bytes[..4] != [0x76, 0x2f, 0x31, 0x01] {
        return Err("not an OpenEXR file (no magic number)".into());
    }
    let flags = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
    let multipart = flags & 0x1000 != 0;
    let mut at = 8;
    loop {
        // one header: attributes until an empty name
        let mut attributes = 0;
        loop {
            let name = cstr(bytes, &mut at)?;
            if name.is_empty() {
                break;
            }
            let kind = cstr(bytes, &mut at)?;
            let size = i32::from_le_bytes(take(bytes, &mut at, 4)?.try_into().expect("4 bytes"));
            let size = usize::try_from(size).map_err(|_| format!("attribute {} has a negative size", lossy(name)))?;
            let value = take(bytes, &mut at, size)?;
            if kind == b"chlist" {
                channels(value)?;
            }
            attributes += 1;
        }
        // a multi-part file ends its headers with an empty one
        if !multipart || attributes == 0 {
            return Ok(());
        }
    }
}

/// The channel list attribute: names (NUL-terminated) each followed by 16 bytes, then a NUL.
fn channels(mut value: &[u8]) -> Result<(), String> {
    loop {
        let end = value.iter().position(|&b| b == 0).ok_or("a channel list without its end")?;
        if end == 0 {
            return Ok(());
        }
        std::str::from_utf8(&value[..end]).map_err(|_| format!("channel name {} is not UTF-8", lossy(&value[..end])))?;
        value = value.get(end + 1 + 16..).ok_or("a channel list cut short")?;
    }
}

fn take<'a>(bytes: &'a [u8], at: &mut usize, n: usize) -> Result<&'a [u8], String> {
    let s = bytes.get(*at..at.checked_add(n).ok_or("an attribute of absurd size")?).ok_or("the header is cut short")?;
    *at += n;
    Ok(s)
}

/// A NUL-terminated name (at most 255 bytes, as OpenEXR's long names).
fn cstr<'a>(bytes: &'a [u8], at: &mut usize) -> Result<&'a [u8], String> {
    let rest = bytes.get(*at..).ok_or("the header is cut short")?;
    let end = rest.iter().take(256).position(|&b| b == 0).ok_or("the header is cut short or holds a name over 255 bytes")?;
    *at += end + 1;
    Ok(&rest[..end])
}

fn lossy(b: &[u8]) -> String {
    format!("{:?}", String::from_utf8_lossy(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(channel: &[u8]) -> Vec<u8> {
        let mut b = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        let mut list = channel.to_vec();
        list.push(0);
        list.extend_from_slice(&[0; 16]);
        list.push(0);
        b.extend_from_slice(b"channels\0chlist\0");
        b.extend_from_slice(&(list.len() as i32).to_le_bytes());
        b.extend_from_slice(&list);
        b.push(0);
        b
    }

    #[test]
    fn channel_names_must_be_utf8_and_attributes_inside_the_file() {
        assert_eq!(check(&header(b"R")), Ok(()));
        assert!(check(&header(b"R\xff")).unwrap_err().contains("not UTF-8"));
        assert!(check(&header(b"R")[..30]).unwrap_err().contains("cut short"));
        assert!(check(b"\x76\x2f\x31\x02rest").unwrap_err().contains("magic"));
        let mut negative = header(b"R");
        negative[24..28].copy_from_slice(&(-5i32).to_le_bytes());
        assert!(check(&negative).unwrap_err().contains("negative"));
    }
}
