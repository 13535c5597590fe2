//! Frame sequences: `raysplat render STAGE --frames FIRST:LAST[:STEP] -o out.####.exr` renders
//! each time code of the range as `--frame` would, to a file named by the pattern.

use raysplat::Error;
use std::path::{Path, PathBuf};

/// Most frames one `--frames` may name (a typo such as `1:100000000` fails before rendering).
const MAX_FRAMES: usize = 100_000;

/// The time codes of `FIRST:LAST[:STEP]` (whole numbers; `STEP` ≥ 1, `LAST` ≥ `FIRST`).
pub fn parse(spec: &str) -> Result<Vec<i64>, Error> {
    let bad = |why: &str| Error::param("frames", format!("{spec:?}: {why} (expected FIRST:LAST or FIRST:LAST:STEP, whole frame numbers, e.g. 1:24 or 1:24:2)"));
    let parts: Vec<&str> = spec.split(':').collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(bad("not a range"));
    }
    let num = |s: &str| s.trim().parse::<i64>().map_err(|_| bad(&format!("{s:?} is not a whole number")));
    let (first, last) = (num(parts[0])?, num(parts[1])?);
    let step = if parts.len() == 3 { num(parts[2])? } else { 1 };
    if step < 1 {
        return Err(bad("the step must be at least 1"));
    }
    if last < first {
        return Err(bad("the last frame comes before the first"));
    }
    let count = ((last - first) / step + 1) as u64;
    if count > MAX_FRAMES as u64 {
        return Err(bad(&format!("{count} frames; at most {MAX_FRAMES}")));
    }
    Ok((0..count as i64).map(|k| first + k * step).collect())
}

/// `path` with the last run of `#` in its file name replaced by `frame`, zero-padded to the run's
/// length (`out.####.exr`, 7 → `out.0007.exr`); `None` when the name has no `#`.
pub fn name(path: &Path, frame: i64) -> Option<PathBuf> {
    let file = path.file_name()?.to_str()?;
    let end = file.rfind('#')? + 1;
    let start = file[..end].trim_end_matches('#').len();
    let width = end - start;
    let named = format!("{}{:0width$}{}", &file[..start], frame, &file[end..]);
    Some(path.with_file_name(named))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_their_errors() {
        assert_eq!(parse("1:4").unwrap(), vec![1, 2, 3, 4]);
        assert_eq!(parse("-2:7:3").unwrap(), vec![-2, 1, 4, 7]);
        assert_eq!(parse("5:5").unwrap(), vec![5]);
        assert_eq!(parse("1:10:4").unwrap(), vec![1, 5, 9]);
        for bad in ["1", "1:2:3:4", "a:3", "1:2.5", "3:1", "1:5:0", "1:5:-1", "0:100000000"] {
            let e = parse(bad).expect_err(bad).to_string();
            assert!(e.contains("invalid parameter frames") && e.contains(bad), "{bad}: {e}");
        }
    }

    #[test]
    fn patterns_pad_the_frame_number() {
        let n = |p: &str, f| name(Path::new(p), f).map(|p| p.display().to_string());
        assert_eq!(n("out/shot.####.exr", 7).as_deref(), Some("out/shot.0007.exr"));
        assert_eq!(n("shot#.exr", 123).as_deref(), Some("shot123.exr"));
        assert_eq!(n("a#/b_##.exr", -3).as_deref(), Some("a#/b_-3.exr"));
        assert_eq!(n("v1_##_x.png", 12345).as_deref(), Some("v1_12345_x.png"));
        assert_eq!(n("plain.exr", 1), None);
    }
}
