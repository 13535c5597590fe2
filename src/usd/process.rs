//! Running the converter: a Python process in a process group of its own (a terminal's Ctrl-C
//! reaches `raysplat`, which ends it: [`crate::io::temporaries::clean_up_all`]), which asks the
//! kernel to kill it when `raysplat` dies (`PR_SET_PDEATHSIG`, on the Python side) and runs under a
//! data-segment limit of the memory left to `raysplat` ([`crate::memory::available`]), so that a
//! malformed stage cannot exhaust the machine.

use super::{find_python, StageOptions, CONVERTER};
use crate::error::{Error, Result};
use crate::io::temporaries;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::Path;
use std::process::{Command, Stdio};

/// The converter's warnings a failed conversion's error message repeats (the first ones).
const MAX_WARNINGS_WITH_ERROR: usize = 10;

/// Convert `input` into `output` with the extracted `.usdz` textures in `textures`; errors name
/// the input as `shown`. Returns the converter's warnings output (stderr).
pub(super) fn run(input: &Path, output: &Path, textures: &Path, opts: &StageOptions, shown: &str) -> Result<String> {
    let file = shown.to_string();
    let python = find_python(opts.python.as_deref()).map_err(|e| match e {
        Error::Usd { message, .. } => Error::Usd { file: file.clone(), message },
        other => other,
    })?;
    let mut cmd = Command::new(&python);
    cmd.arg("-").arg(input).arg(output).args(opts.args());
    cmd.arg("--textures-dir").arg(textures).arg("--parent-pid").arg(std::process::id().to_string());
    let limit = crate::memory::available().map(|b| b.bytes);
    if let Some(l) = limit {
        cmd.arg("--memory-limit").arg(l.to_string());
    }
    cmd.stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::piped()).process_group(0);
    let mut child = cmd.spawn().map_err(|e| Error::Usd { file: file.clone(), message: format!("cannot run {}: {e}", python.display()) })?;
    let group = match temporaries::register_child_group(child.id()) {
        Ok(g) => g,
        Err(e) => {
            let _ = child.wait();
            return Err(e);
        }
    };
    // progress lines are shown as they come; the rest (warnings, the error) is kept
    let err_pipe = child.stderr.take().expect("piped stderr");
    let name = input.file_name().map_or_else(|| file.clone(), |n| n.to_string_lossy().into_owned());
    let reader = std::thread::spawn(move || {
        use std::io::BufRead;
        let mut kept = String::new();
        for line in std::io::BufReader::new(err_pipe).lines().map_while(|l| l.ok()) {
            match line.strip_prefix("progress: ") {
                Some(p) => eprintln!("converting {name}: {p}"),
                None => {
                    kept.push_str(&line);
                    kept.push('\n');
                }
            }
        }
        kept
    });
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().expect("piped stdin");
        // a converter that ended early (a bad argument) closed its stdin: its own error follows
        let _ = stdin.write_all(CONVERTER.as_bytes());
    }
    let out = child.wait_with_output().map_err(|e| Error::Usd { file: file.clone(), message: format!("converter failed: {e}") })?;
    drop(group);
    let stderr = reader.join().unwrap_or_default();
    if out.status.success() {
        return Ok(stderr);
    }
    // The converter prints one `error: <file>: <prim>: <message>` line for user errors.
    let line = stderr.lines().rev().find(|l| l.starts_with("error: ")).map(|l| l.trim_start_matches("error: ").to_string());
    // the warnings printed before the error often explain it (every mesh skipped, say)
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.starts_with("warning: ")).collect();
    let mut context = String::new();
    for w in warnings.iter().take(MAX_WARNINGS_WITH_ERROR) {
        context.push_str("\n  ");
        context.push_str(w);
    }
    if warnings.len() > MAX_WARNINGS_WITH_ERROR {
        context.push_str(&format!("\n  ({} more warnings)", warnings.len() - MAX_WARNINGS_WITH_ERROR));
    }
    let message = match (line, out.status.signal()) {
        (Some(l), _) => strip_file_prefix(&l, input) + &context,
        (None, Some(sig)) => {
            let memory = if stderr.contains("bad_alloc") || stderr.contains("MemoryError") || stderr.contains("Cannot allocate memory") {
                format!(" after running out of memory{}", limit.map_or(String::new(), |l| format!(" (limit {})", crate::memory::human_bytes(l))))
            } else {
                String::new()
            };
            format!("the converter was ended by signal {sig}{memory}{}", last_line(&stderr))
        }
        (None, None) => format!("converter failed ({}){}", out.status, last_line(&stderr)),
    };
    // usd-core's messages name the layer by its resolved (absolute) path: as the user gave it
    let mut message = message.replace(&input.display().to_string(), shown);
    if let Ok(abs) = std::fs::canonicalize(input) {
        message = message.replace(&abs.display().to_string(), shown);
    }
    Err(Error::Usd { file, message })
}

/// The last line of the converter's diagnostics (not a whole traceback), after `: `.
fn last_line(stderr: &str) -> String {
    stderr.lines().rev().map(str::trim).find(|l| !l.is_empty()).map_or(String::new(), |l| format!(": {l}"))
}

/// The converter's error line without its file name (the error names the file as given).
fn strip_file_prefix(line: &str, input: &Path) -> String {
    let p = format!("{}: ", input.display());
    line.strip_prefix(&p).unwrap_or(line).to_string()
}
