//! Quoting for POSIX shells: the farm's batch scripts run the task commands through bash.

/// `s` as one shell word: bare when it holds only characters no shell treats specially, else in
/// single quotes (a single quote inside as `'\''`).
pub fn quote(s: &str) -> String {
    let plain = !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./:=,+%@".contains(c));
    if plain {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::quote;

    /// bash reads each quoted word back as the word.
    #[test]
    fn bash_reads_quoted_words_back() {
        let words = ["plain/path.exr", "", "with space", "it's", "$HOME", "a\"b", "back\\slash", "*?[x]", "new\nline"];
        let line: Vec<String> = words.iter().map(|w| quote(w)).collect();
        let out = std::process::Command::new("bash").arg("-c").arg(format!("printf '%s\\0' {}", line.join(" "))).output().expect("bash");
        let got: Vec<&str> = std::str::from_utf8(&out.stdout).unwrap().split('\0').collect();
        assert_eq!(&got[..words.len()], &words);
    }
}
