//! A cheap look at YAML text before a parser sees it. The files users hand us (map YAML, bench
//! scenarios, routes, parameter files) are small and shallow; a file nested thousands of levels
//! deep (`[[[[...`, or ever deeper indentation) made the YAML parser take tens of seconds. Such
//! text is refused at once, with the line, instead.

/// The deepest nesting of flow collections (`[`, `{`) a file may have.
pub const MAX_FLOW_DEPTH: usize = 64;
/// The widest indentation (columns) a line may have: 64 levels of four spaces.
pub const MAX_INDENT: usize = 256;
/// The largest YAML text accepted (bytes): these files are a few kilobytes.
pub const MAX_YAML_BYTES: usize = 4 << 20;

/// Checks size, flow nesting and indentation; the error says what and where.
pub fn check(text: &[u8]) -> Result<(), String> {
    if text.len() > MAX_YAML_BYTES {
        return Err(format!(
            "{} bytes of YAML, more than the {MAX_YAML_BYTES} accepted",
            text.len()
        ));
    }
    let mut depth = 0usize;
    for (n, line) in text.split(|&b| b == b'\n').enumerate() {
        // A quoted scalar may span lines in YAML, but an unterminated quote must not hide the
        // rest of the file from the check: quotes and comments restart at each line.
        let (mut quote, mut comment) = (None::<u8>, false);
        let indent = line
            .iter()
            .take_while(|&&b| b == b' ' || b == b'\t')
            .count();
        if indent > MAX_INDENT {
            return Err(format!(
                "line {}: indented {indent} columns, more than the {MAX_INDENT} accepted",
                n + 1
            ));
        }
        for &b in line {
            match (quote, b) {
                (Some(q), _) if b == q => quote = None,
                (Some(_), _) => {}
                _ if comment => {}
                (None, b'#') => comment = true,
                (None, b'"' | b'\'') => quote = Some(b),
                (None, b'[' | b'{') => {
                    depth += 1;
                    if depth > MAX_FLOW_DEPTH {
                        return Err(format!(
                            "line {}: nested deeper than {MAX_FLOW_DEPTH} levels",
                            n + 1
                        ));
                    }
                }
                (None, b']' | b'}') => depth = depth.saturating_sub(1),
                _ => {}
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deep_or_huge_text_is_refused_and_ordinary_files_pass() {
        let deep = format!("a: {}1{}", "[".repeat(100_000), "]".repeat(100_000));
        assert!(check(deep.as_bytes()).unwrap_err().contains("line 1"));
        let mut indented = String::new();
        for level in 0..200 {
            indented.push_str(&format!("{}k{level}:\n", "  ".repeat(level)));
        }
        assert!(check(indented.as_bytes()).unwrap_err().contains("indented"));
        assert!(check(&vec![b' '; MAX_YAML_BYTES + 1]).is_err());
        let ordinary = "image: map.pgm # a [comment\nresolution: 0.05\norigin: [-1.0, 2.0, 0.0]\nname: \"[x\"\n";
        assert!(check(ordinary.as_bytes()).is_ok());
    }
}
