//! Errors in the C++ API's words: the library's messages name the command line's flags
//! (`--spp`, `invalid parameter time`); C++ callers set fields of `RenderOptions` and `StageView`,
//! so [`api_message`] renames every flag and parameter that has a field to that field.

use crate::error::Error;

/// Command-line flag (without `--`) or parameter name, and the C++ field that sets it. Flags
/// without a field (`--explicit-rays`, `--emax`, …) keep their names: C++ renders use their
/// defaults.
const FIELDS: &[(&str, &str)] = &[
    ("aa-spp", "aa_spp"),
    ("cache-error", "cache_error"),
    ("camera", "StageView::camera"),
    ("denoise-quality", "denoise_quality"),
    ("density-limit", "density_limit"),
    ("direct-photons", "direct_photons"),
    ("fg-rays", "gather_rays"),
    ("filter-radius", "filter_radius"),
    ("frame", "StageView::frame"),
    ("gather-radius", "gather_radius"),
    ("light-samples", "light_samples"),
    ("max-bandwidth", "max_bandwidth"),
    ("max-depth", "max_depth"),
    ("memory", "memory_budget"),
    ("no-spill", "no_spill"),
    ("resolution", "width/height"),
    ("spill-dir", "spill_dir"),
    ("subdivision-level", "StageView::subdivision_level"),
    ("time", "time_budget"),
];

/// Flags whose C++ field has the same name.
const SAME: &[&str] = &["method", "quality", "spp", "seed", "threads", "photons", "knn", "smoothness", "sensitivity", "glossy", "denoise"];

/// The C++ field that sets a flag or parameter, if there is one.
fn field_of(name: &str) -> Option<&str> {
    FIELDS.iter().find(|(flag, _)| *flag == name).map(|(_, f)| *f).or_else(|| SAME.iter().find(|f| **f == name).copied())
}

/// The C++ field for a flag or parameter name; a name without a field comes back unchanged.
pub fn field(name: &str) -> &str {
    field_of(name).unwrap_or(name)
}

/// `e`'s message with parameter names and `--flags` replaced by the C++ fields that set them.
pub fn api_message(e: &Error) -> String {
    let text = match e {
        Error::Param { name, message } => format!("invalid parameter {}: {message}", field(name)),
        other => other.to_string(),
    };
    rename_flags(&text)
}

/// Replace each `--flag` (a run of lower-case letters and dashes after `--`) that has a field by
/// the field; other flags stay as they are.
fn rename_flags(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find("--") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        let len = after.find(|c: char| !(c.is_ascii_lowercase() || c == '-')).unwrap_or(after.len());
        let flag = after[..len].trim_end_matches('-');
        match field_of(flag) {
            Some(f) if !flag.is_empty() => {
                out.push_str(f);
                rest = &after[flag.len()..];
            }
            _ => {
                out.push_str("--");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_and_flags_become_fields() {
        let e = Error::param("time", "-1 is not a positive number of seconds");
        assert_eq!(api_message(&e), "invalid parameter time_budget: -1 is not a positive number of seconds");
        let e = Error::param("spp", "64x64 at --spp 9 with --method rs needs 1 GiB; lower --resolution or --spp");
        assert_eq!(api_message(&e), "invalid parameter spp: 64x64 at spp 9 with method rs needs 1 GiB; lower width/height or spp");
        let e = Error::param("quality", "--quality applies to --method auto only");
        assert_eq!(api_message(&e), "invalid parameter quality: quality applies to method auto only");
        // flags without a field, a lone "--" and other errors pass through
        let e = Error::param("fg-rays", "--fg-rays and --explicit-rays are both 0 -- see --help");
        assert_eq!(api_message(&e), "invalid parameter gather_rays: gather_rays and --explicit-rays are both 0 -- see --help");
        let e = Error::scene("a--b.rss", "/World", "bad");
        assert_eq!(api_message(&e), "a--b.rss: /World: bad");
    }
}
