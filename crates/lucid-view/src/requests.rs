//! The viewer's requests, parsed from URLs into typed values with every number checked
//! before any work starts: a request names a route from a fixed list and numbers, never a
//! path, so nothing a client sends reaches the file system, and sizes are capped so no
//! request asks for unbounded work.

use lucid_scene::camera_path::camera_from_pose;
use lucid_scene::{PinholeCamera, Split};

/// The longest URL served (a pose and its options take ~400 bytes).
pub const MAX_URL_BYTES: usize = 4096;
/// The largest image side a render may ask for.
pub const MAX_SIDE: u32 = 4096;
/// The most pixels a render may ask for (a 2048² view).
pub const MAX_PIXELS: u64 = 2048 * 2048;
/// The most rays per pixel over a thin lens.
pub const MAX_LENS_RAYS: usize = 256;

/// What a request asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum Route {
    /// The page.
    Page,
    /// The page's script.
    Script,
    /// The model, its frame and the dataset's cameras, as JSON.
    Info,
    /// A training run's progress (step, losses, held-out PSNR over time), as JSON.
    Status,
    /// A render at a camera.
    Render(ViewRequest),
    /// The depth under one pixel of a camera (click to focus).
    Depth {
        /// The camera and lens.
        view: ViewRequest,
        /// Pixel column.
        x: u32,
        /// Pixel row.
        y: u32,
    },
    /// A dataset image, composited on the model's background.
    Truth(FrameRef),
    /// A render at a dataset camera scored against its image: the render or its error map.
    Compare {
        /// Which image.
        frame: FrameRef,
        /// The error map instead of the render.
        error: bool,
    },
}

/// What a render shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageMode {
    /// Colour on the model's background.
    Colour,
    /// Expected depth, colour-mapped between the view's nearest and farthest depth.
    Depth,
}

/// How a render is sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameFormat {
    /// A PNG.
    Png,
    /// The 8-bit RGB bytes, rows top to bottom, the size in `X-Width`/`X-Height` (the page's
    /// frames: nothing to encode or decode on either side of a loopback connection).
    Rgb,
}

/// A camera to render, with its lens.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewRequest {
    /// The pinhole at the lens centre.
    pub camera: PinholeCamera,
    /// `(aperture radius, focus distance)` of a thin lens, in scene units.
    pub lens: Option<(f32, f32)>,
    /// Rays per pixel over the aperture.
    pub lens_rays: usize,
    /// Colour or depth.
    pub mode: ImageMode,
    /// PNG or raw bytes.
    pub format: FrameFormat,
}

/// One image of the dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRef {
    /// Its split.
    pub split: Split,
    /// Its index in the split.
    pub index: usize,
}

/// A request refused, with the HTTP status and the reason shown to the client.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    /// 4xx status.
    pub status: u16,
    /// What was wrong.
    pub reason: String,
}

impl Refusal {
    fn bad(reason: impl Into<String>) -> Self {
        Self { status: 400, reason: reason.into() }
    }
}

/// Parses a `GET` request's URL (path and query).
pub fn parse(url: &str) -> Result<Route, Refusal> {
    if url.len() > MAX_URL_BYTES {
        return Err(Refusal { status: 414, reason: format!("the URL is longer than {MAX_URL_BYTES} bytes") });
    }
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    let query = Query::new(query)?;
    match path {
        "/" | "/index.html" => Ok(Route::Page),
        "/viewer.js" => Ok(Route::Script),
        "/api/info" => Ok(Route::Info),
        "/api/status" => Ok(Route::Status),
        "/api/render" => Ok(Route::Render(query.view()?)),
        "/api/depth" => {
            let view = query.view()?;
            let (w, h) = (view.camera.intrinsics.width, view.camera.intrinsics.height);
            let x = query.integer("x", 0, u64::from(w) - 1)? as u32;
            let y = query.integer("y", 0, u64::from(h) - 1)? as u32;
            Ok(Route::Depth { view, x, y })
        }
        "/api/truth" => Ok(Route::Truth(query.frame()?)),
        "/api/compare" => {
            let error = match query.get("mode").unwrap_or("colour") {
                "colour" => false,
                "error" => true,
                other => return Err(Refusal::bad(format!("mode '{other}' must be colour or error"))),
            };
            Ok(Route::Compare { frame: query.frame()?, error })
        }
        _ => Err(Refusal { status: 404, reason: "no such page".into() }),
    }
}

/// A query string's keys and values (percent-decoded).
struct Query(Vec<(String, String)>);

impl Query {
    fn new(query: &str) -> Result<Self, Refusal> {
        let pairs: Vec<(String, String)> =
            form_urlencoded::parse(query.as_bytes()).map(|(k, v)| (k.into_owned(), v.into_owned())).collect();
        for (i, (key, _)) in pairs.iter().enumerate() {
            if pairs[..i].iter().any(|(k, _)| k == key) {
                return Err(Refusal::bad(format!("'{key}' is given twice")));
            }
        }
        Ok(Self(pairs))
    }

    fn get(&self, key: &str) -> Option<&str> {
        self.0.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    fn required(&self, key: &str) -> Result<&str, Refusal> {
        self.get(key).ok_or_else(|| Refusal::bad(format!("'{key}' is missing")))
    }

    fn integer(&self, key: &str, min: u64, max: u64) -> Result<u64, Refusal> {
        let text = self.required(key)?;
        text.parse::<u64>()
            .ok()
            .filter(|v| (min..=max).contains(v))
            .ok_or_else(|| Refusal::bad(format!("'{key}' = '{text}' must be an integer in {min}..={max}")))
    }

    fn number(&self, key: &str) -> Result<Option<f64>, Refusal> {
        self.get(key)
            .map(|text| {
                text.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| Refusal::bad(format!("'{key}' = '{text}' is not a finite number")))
            })
            .transpose()
    }

    /// `c2w` (16 comma-separated numbers, row-major OpenGL camera-to-world), `fov` (vertical,
    /// degrees), `w`, `h`, and optionally `aperture` and `focus` (scene units), `lens_rays`
    /// `mode` (`colour` or `depth`) and `format` (`png` or `rgb`).
    fn view(&self) -> Result<ViewRequest, Refusal> {
        let w = self.integer("w", 1, u64::from(MAX_SIDE))? as u32;
        let h = self.integer("h", 1, u64::from(MAX_SIDE))? as u32;
        if u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(Refusal::bad(format!("{w}x{h} is more than the {MAX_PIXELS} pixels a render may have")));
        }
        let pose: Vec<f32> = self
            .required("c2w")?
            .split(',')
            .map(|v| v.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| Refusal::bad("'c2w' must be 16 comma-separated numbers"))?;
        let fov = self.number("fov")?.ok_or_else(|| Refusal::bad("'fov' is missing"))?;
        let camera = camera_from_pose(&pose, fov, w, h).map_err(Refusal::bad)?;
        let aperture = self.number("aperture")?.unwrap_or(0.0);
        let lens = if aperture > 0.0 {
            let focus =
                self.number("focus")?.ok_or_else(|| Refusal::bad("'focus' is missing (the aperture is open)"))?;
            if focus <= 0.0 {
                return Err(Refusal::bad(format!("'focus' = {focus} must be positive")));
            }
            Some((aperture as f32, focus as f32))
        } else if aperture < 0.0 {
            return Err(Refusal::bad(format!("'aperture' = {aperture} must be zero or positive")));
        } else {
            None
        };
        let lens_rays = match self.get("lens_rays") {
            Some(_) => self.integer("lens_rays", 1, MAX_LENS_RAYS as u64)? as usize,
            None => lucid_scene::evaluation::LENS_RAYS,
        };
        let mode = match self.get("mode").unwrap_or("colour") {
            "colour" => ImageMode::Colour,
            "depth" => ImageMode::Depth,
            other => return Err(Refusal::bad(format!("mode '{other}' must be colour or depth"))),
        };
        let format = match self.get("format").unwrap_or("png") {
            "png" => FrameFormat::Png,
            "rgb" => FrameFormat::Rgb,
            other => return Err(Refusal::bad(format!("format '{other}' must be png or rgb"))),
        };
        Ok(ViewRequest { camera, lens, lens_rays, mode, format })
    }

    /// `split` (train, val or test) and `index`; the index is checked against the dataset
    /// where the frame is used.
    fn frame(&self) -> Result<FrameRef, Refusal> {
        let split = match self.required("split")? {
            "train" => Split::Train,
            "val" => Split::Val,
            "test" => Split::Test,
            other => return Err(Refusal::bad(format!("split '{other}' must be train, val or test"))),
        };
        let index = self.integer("index", 0, u32::MAX as u64)? as usize;
        Ok(FrameRef { split, index })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const POSE: &str = "1,0,0,0,0,1,0,0,0,0,1,4,0,0,0,1";

    #[test]
    fn a_render_request_names_its_camera() {
        let url = format!("/api/render?c2w={}&fov=90&w=40&h=20&aperture=0.1&focus=3.5&lens_rays=8", POSE);
        let Route::Render(view) = parse(&url).unwrap() else { panic!("not a render") };
        let k = view.camera.intrinsics;
        assert_eq!((k.width, k.height), (40, 20));
        // A 90° vertical field of view: the focal length is half the height.
        assert!((k.fy - 10.0).abs() < 1e-4 && (k.fx - 10.0).abs() < 1e-4);
        assert_eq!(view.camera.position(), glam::Vec3::new(0.0, 0.0, 4.0));
        assert_eq!(view.lens, Some((0.1, 3.5)));
        assert_eq!(view.lens_rays, 8);
        assert_eq!((view.mode, view.format), (ImageMode::Colour, FrameFormat::Png));
        // The browser's URLSearchParams encodes the commas.
        let encoded = format!("/api/render?c2w={}&fov=90&w=40&h=20&mode=depth&format=rgb", POSE.replace(',', "%2C"));
        let Route::Render(view) = parse(&encoded).unwrap() else { panic!("not a render") };
        assert_eq!((view.lens, view.mode, view.format), (None, ImageMode::Depth, FrameFormat::Rgb));
    }

    #[test]
    fn paths_outside_the_routes_are_not_found() {
        for url in ["/../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/api/../../etc/passwd", "/viewer.js/..", "//etc"]
        {
            assert_eq!(parse(url).unwrap_err().status, 404, "{url}");
        }
    }

    #[test]
    fn bad_numbers_are_refused_with_a_reason() {
        let render = |rest: &str| parse(&format!("/api/render?c2w={POSE}&{rest}")).unwrap_err();
        let cases = [
            ("fov=50&w=100000&h=100000", "'w'"),
            ("fov=50&w=4096&h=4096", "pixels"),
            ("fov=50&w=0&h=10", "'w'"),
            ("fov=500&w=10&h=10", "fov"),
            ("fov=nan&w=10&h=10", "finite"),
            // Below 180 as a double, 180 once rounded to the camera's f32.
            ("fov=179.999999&w=10&h=10", "fov"),
            ("fov=1e-50&w=10&h=10", "fov"),
            ("fov=50&w=10&h=10&aperture=0.1", "focus"),
            ("fov=50&w=10&h=10&aperture=-1", "aperture"),
            ("fov=50&w=10&h=10&lens_rays=100000", "lens_rays"),
            ("fov=50&w=10&h=10&mode=x", "mode"),
            ("fov=50&w=10&h=10&format=jpeg", "format"),
            ("fov=50&w=10&h=10&w=20", "twice"),
        ];
        for (rest, want) in cases {
            let refusal = render(rest);
            assert_eq!(refusal.status, 400, "{rest}");
            assert!(refusal.reason.contains(want), "{rest}: {}", refusal.reason);
        }
        let sheared = parse("/api/render?c2w=2,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1&fov=50&w=10&h=10").unwrap_err();
        assert!(sheared.reason.contains("rigid"), "{}", sheared.reason);
        let short = parse("/api/render?c2w=1,2,3&fov=50&w=10&h=10").unwrap_err();
        assert!(short.reason.contains("16"), "{}", short.reason);
        let outside = parse(&format!("/api/depth?c2w={POSE}&fov=50&w=10&h=10&x=10&y=0")).unwrap_err();
        assert!(outside.reason.contains("'x'"), "{}", outside.reason);
        assert_eq!(parse(&format!("/api/render?c2w={}", "1".repeat(5000))).unwrap_err().status, 414);
        assert!(parse("/api/truth?split=holdout&index=0").unwrap_err().reason.contains("split"));
        assert!(parse("/api/truth?split=test&index=-1").unwrap_err().reason.contains("'index'"));
    }

    #[test]
    fn frames_are_named_by_split_and_index() {
        assert_eq!(
            parse("/api/compare?split=val&index=3&mode=error").unwrap(),
            Route::Compare { frame: FrameRef { split: Split::Val, index: 3 }, error: true }
        );
        assert_eq!(
            parse("/api/truth?split=train&index=0").unwrap(),
            Route::Truth(FrameRef { split: Split::Train, index: 0 })
        );
    }
}
