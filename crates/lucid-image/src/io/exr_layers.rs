//! Which channels of an OpenEXR file are the image: files hold layers (channel-name prefixes
//! such as Blender's `ViewLayer.Combined.R`) and parts (multi-part files, each with a name),
//! and only one of them is the picture a reader wants.
//!
//! The colour image is, in order: the layer [`set_layer`] names; the plain `R, G, B(, A)`
//! channels; a beauty layer (`*.Combined`, `*.Image`, `rgba`, `beauty`); the only layer with
//! R, G and B. A depth buffer is the layer named `Depth` or `Z`, or the only single-channel
//! one. Anything else is an error that lists the layers, never a guess.

use std::collections::BTreeMap;
use std::sync::OnceLock;

/// The layer names the beauty pass goes by, last path component, lower case.
const BEAUTY: [&str; 6] = ["combined", "image", "rgba", "beauty", "color", "colour"];
/// Channel names of a single-channel image, in order of preference.
const GREY: [&str; 5] = ["Y", "Z", "DEPTH", "L", "V"];

static CHOSEN_LAYER: OnceLock<String> = OnceLock::new();

/// Names the layer (or part) that every EXR read in this process takes its image from, as
/// the layer list of an error shows it (`ViewLayer.Combined`); once per process.
pub fn set_layer(name: &str) -> Result<(), String> {
    CHOSEN_LAYER.set(name.to_string()).map_err(|_| "the EXR layer is already chosen".to_string())
}

/// What a reader wants from a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Want {
    /// The picture: RGB(A), or a grey image where the file has no colour.
    Colour,
    /// A depth buffer.
    Depth,
}

/// One channel, by the part it is in and its position in the part's list.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelAt {
    /// The part.
    pub part: usize,
    /// The channel within it.
    pub index: usize,
}

/// The channels to read as R, G, B and A (a grey image repeats one; no alpha reads as 1).
pub type Sources = [Option<ChannelAt>; 4];

/// The channels of one layer, by upper-case short name.
#[derive(Default, Debug)]
struct Layer {
    channels: BTreeMap<String, ChannelAt>,
}

impl Layer {
    fn get(&self, name: &str) -> Option<ChannelAt> {
        self.channels.get(name).copied()
    }

    fn colour(&self) -> Option<Sources> {
        Some([Some(self.get("R")?), Some(self.get("G")?), Some(self.get("B")?), self.get("A")])
    }

    fn grey(&self) -> Option<Sources> {
        let only = (self.channels.len() == 1).then(|| self.channels.values().next().copied()).flatten();
        let g = GREY.iter().find_map(|n| self.get(n)).or(only)?;
        Some([Some(g), Some(g), Some(g), None])
    }
}

/// Chooses the channels that are the image. `parts` gives each part's name and channel names
/// (in the file's order); the error says why no layer is the one and lists them all.
pub fn choose(parts: &[(Option<String>, Vec<String>)], want: Want) -> Result<Sources, String> {
    choose_layer(parts, want, CHOSEN_LAYER.get().map(String::as_str))
}

fn choose_layer(parts: &[(Option<String>, Vec<String>)], want: Want, named: Option<&str>) -> Result<Sources, String> {
    let mut layers: BTreeMap<String, Layer> = BTreeMap::new();
    for (part, (part_name, channels)) in parts.iter().enumerate() {
        for (index, name) in channels.iter().enumerate() {
            let (prefix, short) = name.rsplit_once('.').unwrap_or(("", name));
            let path: Vec<&str> =
                [part_name.as_deref().unwrap_or(""), prefix].into_iter().filter(|s| !s.is_empty()).collect();
            let key = path.join(".");
            layers.entry(key).or_default().channels.insert(short.to_ascii_uppercase(), ChannelAt { part, index });
        }
    }
    let shown = || {
        layers
            .iter()
            .map(|(k, l)| {
                let names: Vec<&str> = l.channels.keys().map(String::as_str).collect();
                format!("{} ({})", if k.is_empty() { "<plain>" } else { k }, names.join(","))
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let last = |key: &str| key.rsplit('.').next().unwrap_or("").to_ascii_lowercase();
    if let Some(named) = named {
        let matches = |k: &str| k.eq_ignore_ascii_case(named) || last(k) == named.to_ascii_lowercase();
        let Some((_, layer)) = layers.iter().find(|(k, _)| matches(k)) else {
            return Err(format!("no layer named '{named}' (layers: {})", shown()));
        };
        return layer.colour().or_else(|| layer.grey()).ok_or_else(|| {
            format!("layer '{named}' has neither R, G, B nor a single grey channel (layers: {})", shown())
        });
    }
    let pick = |candidates: Vec<(&String, Sources)>, what: &str, names: &[&str]| -> Result<Option<Sources>, String> {
        if let Some((_, s)) = candidates.iter().find(|(k, _)| k.is_empty()) {
            return Ok(Some(*s));
        }
        for name in names {
            if let Some((_, s)) = candidates.iter().find(|(k, _)| last(k) == *name) {
                return Ok(Some(*s));
            }
        }
        match candidates.as_slice() {
            [] => Ok(None),
            [(_, s)] => Ok(Some(*s)),
            _ => Err(format!(
                "holds several {what} layers and none is plain or named {} (layers: {}); choose one with --exr-layer",
                names.join("/"),
                shown()
            )),
        }
    };
    let colours: Vec<(&String, Sources)> = layers.iter().filter_map(|(k, l)| Some((k, l.colour()?))).collect();
    let greys: Vec<(&String, Sources)> =
        layers.iter().filter(|(_, l)| l.colour().is_none()).filter_map(|(k, l)| Some((k, l.grey()?))).collect();
    let found = match want {
        Want::Colour => match pick(colours, "colour", &BEAUTY)? {
            Some(s) => Some(s),
            None => pick(greys, "grey", &[])?,
        },
        Want::Depth => pick(greys, "single-channel", &["depth", "z"])?,
    };
    found.ok_or_else(|| match want {
        Want::Colour => format!("no R/G/B or single grey channel in any layer (layers: {})", shown()),
        Want::Depth => format!("no depth channel (Z, Y or a single one) in any layer (layers: {})", shown()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(name: Option<&str>, channels: &[&str]) -> (Option<String>, Vec<String>) {
        (name.map(String::from), channels.iter().map(|c| c.to_string()).collect())
    }

    fn at(part: usize, index: usize) -> Option<ChannelAt> {
        Some(ChannelAt { part, index })
    }

    #[test]
    fn blenders_combined_layer_is_the_image_not_its_other_passes() {
        // Blender sorts channels by name: the AO pass comes first.
        let blender = [part(
            None,
            &[
                "ViewLayer.AO.B",
                "ViewLayer.AO.G",
                "ViewLayer.AO.R",
                "ViewLayer.Combined.A",
                "ViewLayer.Combined.B",
                "ViewLayer.Combined.G",
                "ViewLayer.Combined.R",
                "ViewLayer.Depth.Z",
            ],
        )];
        assert_eq!(choose_layer(&blender, Want::Colour, None).unwrap(), [at(0, 6), at(0, 5), at(0, 4), at(0, 3)]);
        assert_eq!(choose_layer(&blender, Want::Depth, None).unwrap(), [at(0, 7), at(0, 7), at(0, 7), None]);
        assert_eq!(choose_layer(&blender, Want::Colour, Some("AO")).unwrap(), [at(0, 2), at(0, 1), at(0, 0), None]);
        let missing = choose_layer(&blender, Want::Colour, Some("Shadow")).unwrap_err();
        assert!(missing.contains("ViewLayer.Combined (A,B,G,R)") && missing.contains("'Shadow'"), "{missing}");
    }

    #[test]
    fn plain_rgba_wins_over_an_aov_and_a_part_over_the_first_part() {
        let aov = [part(None, &["A", "AOV.B", "AOV.G", "AOV.R", "B", "G", "R"])];
        assert_eq!(choose_layer(&aov, Want::Colour, None).unwrap(), [at(0, 6), at(0, 5), at(0, 4), at(0, 0)]);
        // A multi-part file whose first part is depth.
        let parts = [part(Some("depth"), &["Z"]), part(Some("rgba"), &["A", "B", "G", "R"])];
        assert_eq!(choose_layer(&parts, Want::Colour, None).unwrap(), [at(1, 3), at(1, 2), at(1, 1), at(1, 0)]);
        assert_eq!(choose_layer(&parts, Want::Depth, None).unwrap(), [at(0, 0), at(0, 0), at(0, 0), None]);
        // A single grey channel of any name is a grey image.
        let grey = [part(None, &["luminance"])];
        assert_eq!(choose_layer(&grey, Want::Colour, None).unwrap(), [at(0, 0), at(0, 0), at(0, 0), None]);
    }

    #[test]
    fn two_colour_layers_and_no_beauty_are_an_error_listing_them() {
        let two = [part(None, &["left.B", "left.G", "left.R", "right.B", "right.G", "right.R"])];
        let err = choose_layer(&two, Want::Colour, None).unwrap_err();
        assert!(err.contains("left (B,G,R)") && err.contains("right (B,G,R)") && err.contains("--exr-layer"), "{err}");
        assert_eq!(choose_layer(&two, Want::Colour, Some("right")).unwrap()[0], at(0, 5));
        let none = [part(None, &["U", "V2"])];
        assert!(choose_layer(&none, Want::Colour, None).unwrap_err().contains("no R/G/B"));
    }
}
