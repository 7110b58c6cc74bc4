//! Content negotiation for a stored frame: JSON (the default) or the
//! binary frame, from the request's `Accept` header (RFC 9110 §12.5.1:
//! media types are case-insensitive, `q` weighs them, `q=0` refuses).

/// Whether `accept` asks for `application/octet-stream` over JSON: the
/// binary type named with a weight above zero, and above JSON's (JSON's
/// weight is its own, else `application/*`'s, else `*/*`'s; on a tie with
/// JSON reached only through a wildcard, the type named wins).
pub fn prefers_binary(accept: &str) -> bool {
    let (mut binary, mut json, mut json_named) = (None::<f32>, None::<(u8, f32)>, false);
    for range in accept.split(',') {
        let mut parts = range.split(';');
        let media = parts.next().unwrap_or("").trim().to_ascii_lowercase();
        let q = parts
            .filter_map(|p| p.trim().strip_prefix("q=").or(p.trim().strip_prefix("Q=")))
            .find_map(|v| v.trim().parse::<f32>().ok())
            .unwrap_or(1.0)
            .clamp(0.0, 1.0);
        // How specifically a range names JSON: 3 exactly, 2 `application/*`, 1 `*/*`.
        let json_rank = match media.as_str() {
            "application/json" => 3,
            "application/*" => 2,
            "*/*" => 1,
            _ => 0,
        };
        if media == "application/octet-stream" {
            binary = Some(binary.map_or(q, |b: f32| b.max(q)));
        }
        if json_rank > 0 && json.is_none_or(|(rank, _)| json_rank > rank) {
            json = Some((json_rank, q));
            json_named = json_rank == 3;
        }
    }
    match (binary, json) {
        (Some(b), _) if b <= 0.0 => false,
        (Some(_), None) => true,
        (Some(b), Some((_, j))) => b > j || (b == j && !json_named),
        (None, _) => false,
    }
}

#[cfg(test)]
mod tests {
    use super::prefers_binary;

    #[test]
    fn weights_and_case_decide_between_json_and_binary() {
        for (accept, binary) in [
            ("application/octet-stream", true),
            ("APPLICATION/OCTET-STREAM", true),
            ("application/octet-stream;q=0", false),
            ("application/json, application/octet-stream;q=0.1", false),
            ("application/json;q=0.5, application/octet-stream", true),
            ("application/octet-stream, */*", true),
            ("application/octet-stream, application/json", false),
            ("*/*", false),
            ("application/json", false),
            ("text/html, application/octet-stream; q=0.8", true),
            ("", false),
        ] {
            assert_eq!(prefers_binary(accept), binary, "{accept:?}");
        }
    }
}
