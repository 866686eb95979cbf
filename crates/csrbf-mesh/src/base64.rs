//! Base64 (RFC 4648, with padding): glTF's data URIs, VTK XML's inline
//! and appended arrays.

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

fn b64_value(c: u8) -> Option<u32> {
    Some(match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => return None,
    } as u32)
}

/// Decodes base64 (white space ignored) four characters at a time, so that
/// pieces encoded apart and joined (VTK's compressed header and data) read
/// as the joined bytes. `Err` holds the index of the first bad character.
pub(crate) fn decode(text: &[u8]) -> Result<Vec<u8>, usize> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut quad = [0u8; 4];
    let mut n = 0;
    for (i, &c) in text.iter().enumerate() {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c != b'=' && b64_value(c).is_none() {
            return Err(i);
        }
        quad[n] = c;
        n += 1;
        if n == 4 {
            n = 0;
            let pad = quad.iter().filter(|&&c| c == b'=').count();
            if pad > 2 || quad[..4 - pad].contains(&b'=') {
                return Err(i);
            }
            let mut acc = 0u32;
            for &q in &quad[..4 - pad] {
                acc = (acc << 6) | b64_value(q).unwrap_or(0);
            }
            acc <<= 6 * pad as u32;
            out.extend_from_slice(&acc.to_be_bytes()[1..4 - pad]);
        }
    }
    if n != 0 {
        return Err(text.len());
    }
    Ok(out)
}

/// Base64 with padding (RFC 4648).
pub(crate) fn encode_into(data: &[u8], out: &mut Vec<u8>) {
    for c in data.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            out.push(if k <= c.len() {
                B64[(n >> (18 - 6 * k) & 63) as usize]
            } else {
                b'='
            });
        }
    }
}

/// Base64 of `data` as text.
pub(crate) fn encode(data: &[u8]) -> String {
    let mut out = Vec::with_capacity(data.len().div_ceil(3) * 4);
    encode_into(data, &mut out);
    String::from_utf8(out).unwrap_or_default()
}

/// [`decode`], taking a last group without its padding (as some writers
/// of data URIs leave it off).
pub(crate) fn decode_lenient(text: &str) -> Option<Vec<u8>> {
    let mut t: Vec<u8> = text.bytes().filter(|c| !c.is_ascii_whitespace()).collect();
    while !t.len().is_multiple_of(4) {
        t.push(b'=');
    }
    decode(&t).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_and_joins_padded_pieces() {
        for n in 0..20 {
            let data: Vec<u8> = (0..n as u8).map(|i| i.wrapping_mul(37)).collect();
            let mut s = Vec::new();
            encode_into(&data, &mut s);
            assert_eq!(decode(&s), Ok(data));
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        encode_into(b"Ma", &mut a);
        encode_into(b"n", &mut b);
        assert_eq!(a, b"TWE=");
        a.extend_from_slice(&b);
        assert_eq!(decode(&a), Ok(b"Man".to_vec()));
        assert!(decode(b"TW=E").is_err());
        assert!(decode(b"TWE").is_err());
    }

    #[test]
    fn text_and_unpadded_data_uris() {
        assert_eq!(encode(b"Man"), "TWFu");
        assert_eq!(encode(b"Ma"), "TWE=");
        assert_eq!(decode_lenient("TWE"), Some(b"Ma".to_vec()));
        assert_eq!(decode_lenient("TW Fu\n"), Some(b"Man".to_vec()));
        assert_eq!(decode_lenient("T*Fu"), None);
    }
}
