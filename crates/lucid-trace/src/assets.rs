//! Data files compiled into Lucid, so that built-in scenes (which travel without a folder) can
//! use file-based materials: a scene names one as `file = "builtin:NAME"`. Measured tables are
//! not among them — a MERL table is 35 MB — a scene tabulates one from an analytic material
//! instead (`type = "measured"` with `tabulate`).

/// The prefix that marks a built-in asset in a scene file's `file` keys.
pub const PREFIX: &str = "builtin:";

const ASSETS: [(&str, &str); 1] =
    [("neural/plum-lacquer.json", include_str!("../../../configs/assets/neural/plum-lacquer.json"))];

/// The text of the built-in asset `name` (without the prefix).
pub fn text(name: &str) -> Option<&'static str> {
    ASSETS.iter().find(|(n, _)| *n == name).map(|(_, text)| *text)
}

/// The built-in assets' names.
pub fn names() -> impl Iterator<Item = &'static str> {
    ASSETS.iter().map(|(name, _)| *name)
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_asset_is_found_by_its_name_and_no_other() {
        for name in super::names() {
            assert!(super::text(name).is_some_and(|t| !t.is_empty()), "{name}");
        }
        assert!(super::text("neural/missing.json").is_none());
    }
}
