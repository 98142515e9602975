//! OpenEXR files: the plain RGB image of [`super::write`] / [`super::read`], and the image with
//! what produced it ([`Provenance`], as attributes) and its variance (as a layer).
//!
//! A file written with [`Extras`] is still a plain RGB image to every reader: one part whose
//! channels `R`, `G`, `B` are the image, beside the channels `variance.R`, `variance.G`,
//! `variance.B` (the per-pixel variance of one sample; OpenEXR's layer naming, which viewers
//! show as a layer `variance`) and, for a render in K independent batches (`render
//! --batches K`), `meanVariance.R/G/B` (the variance of each pixel's mean estimated from the K
//! batch means, [`BatchVariance`]) with the attribute `brdfwave.batches` = K (an `int`). The
//! attributes are in the part's header: the standard
//! `comments` (one readable line) and `capDate` (UTC), and the custom `brdfwave.*` attributes
//! of [`Provenance`] (`exrheader` lists them): numbers as `int` (or `double` above 2^31 − 1 and
//! for seconds), the rest as `string`.

use super::{check_size, open, Image, ImageError};
use exr::meta::attribute::{AttributeValue, Text};
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::ops::Range;
use std::path::Path;

/// What produced an image; every field is optional (`None` is not written).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Provenance {
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// The sample indices, START..END.
    pub samples: Option<Range<u32>>,
    pub seed: Option<u32>,
    pub sampler: Option<String>,
    pub max_depth: Option<u32>,
    /// The render's time (for a merge, the parts' times added).
    pub render_seconds: Option<f64>,
    /// The scene file as given.
    pub scene: Option<String>,
    /// FNV-1a of the scene file's bytes, 16 hex digits.
    pub scene_file_hash: Option<String>,
    /// The hash of the scene as rendered (`film::scene_hash`: settings and overrides included,
    /// the sample count not), the one partial films are merged by.
    pub scene_hash: Option<String>,
    /// `render --set` overrides, as given.
    pub overrides: Vec<String>,
    /// `film::code_version`: the package version and the commit.
    pub version: Option<String>,
    pub backend: Option<String>,
    pub device: Option<String>,
}

/// The variance of each pixel's mean estimated from `batches` independent batch means: s² / K,
/// s² the sample variance of the K batch means (`render --batches K`). Unlike the variance of
/// one sample divided by the spp, it is the variance of the pixel's estimate for every sampler,
/// stratified or not, as long as the batches are independent.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchVariance {
    pub variance: Image,
    /// K >= 2.
    pub batches: u32,
}

/// What an EXR file holds besides the image.
#[derive(Clone, Copy, Debug, Default)]
pub struct Extras<'a> {
    /// Written as the channels `variance.R/G/B`; the same size as the image.
    pub variance: Option<&'a Image>,
    /// Written as the channels `meanVariance.R/G/B` and the attribute `brdfwave.batches`.
    pub batch_variance: Option<&'a BatchVariance>,
    pub provenance: Option<&'a Provenance>,
}

impl Extras<'_> {
    fn is_empty(&self) -> bool {
        self.variance.is_none() && self.batch_variance.is_none() && self.provenance.is_none()
    }
}

/// An image read with what its file carries besides (nothing for PNG and PFM).
#[derive(Clone, Debug, PartialEq)]
pub struct Layered {
    pub image: Image,
    pub variance: Option<Image>,
    pub batch_variance: Option<BatchVariance>,
    pub provenance: Provenance,
}

/// The channel-name prefix of the variance layer.
pub const VARIANCE_LAYER: &str = "variance";

/// The channel-name prefix of the layer of the variance of the means from batches.
pub const MEAN_VARIANCE_LAYER: &str = "meanVariance";

/// The attribute that gives the number of batches of [`MEAN_VARIANCE_LAYER`].
const BATCHES_ATTRIBUTE: &str = "batches";

const PREFIX: &str = "brdfwave.";

pub(super) fn write_exr(
    file: &mut File,
    path: &Path,
    img: &Image,
    extras: &Extras,
) -> Result<(), ImageError> {
    use exr::prelude::{Encoding, SpecificChannels, Vec2, WritableImage};
    let exr_error = |source| ImageError::ExrWrite {
        path: path.to_path_buf(),
        source,
    };
    if extras.is_empty() {
        let w = img.width as usize;
        let data = &img.data;
        let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let p = data[y * w + x];
            (p[0], p[1], p[2])
        });
        return exr::prelude::Image::from_encoded_channels(
            (w, img.height as usize),
            Encoding::SMALL_LOSSLESS,
            channels,
        )
        .write()
        .to_buffered(BufWriter::new(file))
        .map_err(exr_error);
    }
    let layers = [
        ("variance", extras.variance),
        (
            "variance of the means",
            extras.batch_variance.map(|b| &b.variance),
        ),
    ];
    for (what, v) in layers {
        if let Some(v) = v.filter(|v| !v.same_size(img)) {
            return Err(ImageError::InvalidImage {
                path: path.to_path_buf(),
                reason: format!(
                    "the {what} is {}x{}, the image {}x{}",
                    v.width, v.height, img.width, img.height
                ),
            });
        }
    }
    if let Some(b) = extras.batch_variance.filter(|b| b.batches < 2) {
        return Err(ImageError::InvalidImage {
            path: path.to_path_buf(),
            reason: format!(
                "a variance of the means from {} batch(es): it takes at least 2",
                b.batches
            ),
        });
    }
    layered_image(img, extras)
        .write()
        .to_buffered(BufWriter::new(file))
        .map_err(exr_error)
}

fn layered_image(
    img: &Image,
    extras: &Extras,
) -> exr::prelude::Image<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>>
{
    use exr::prelude::{
        AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, SmallVec,
    };
    let channel = |name: &str, src: &Image, c: usize| {
        AnyChannel::new(
            name,
            FlatSamples::F32(src.data.iter().map(|p| p[c]).collect()),
        )
    };
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        list.push(channel(name, img, c));
        if let Some(v) = extras.variance {
            list.push(channel(&format!("{VARIANCE_LAYER}.{name}"), v, c));
        }
        if let Some(b) = extras.batch_variance {
            list.push(channel(
                &format!("{MEAN_VARIANCE_LAYER}.{name}"),
                &b.variance,
                c,
            ));
        }
    }
    let mut attributes = LayerAttributes::default();
    if let Some(p) = extras.provenance {
        attributes.comments = Some(text(&p.summary()));
        attributes.capture_date = Some(text(&capture_date(std::time::SystemTime::now())));
        attributes.other = p.attributes();
    }
    if let Some(b) = extras.batch_variance {
        attributes.other.insert(
            text(&format!("{PREFIX}{BATCHES_ATTRIBUTE}")),
            AttributeValue::I32(i32::try_from(b.batches).unwrap_or(i32::MAX)),
        );
    }
    let size = (img.width as usize, img.height as usize);
    exr::prelude::Image::from_layer(Layer::new(
        size,
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    ))
}

/// UTF-8 bytes as EXR text (the format's text is bytes; OpenEXR reads it as UTF-8).
fn text(s: &str) -> Text {
    Text::from_slice_unchecked(s.as_bytes())
}

fn string(t: &Text) -> String {
    String::from_utf8_lossy(t.as_slice()).into_owned()
}

/// EXR's `capDate` format, `YYYY:MM:DD hh:mm:ss`, in UTC.
fn capture_date(t: std::time::SystemTime) -> String {
    let secs = t
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}:{m:02}:{d:02} {:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

impl Provenance {
    /// One readable line for the standard `comments` attribute.
    pub fn summary(&self) -> String {
        let mut parts = vec![format!(
            "brdfwave {}",
            self.version.as_deref().unwrap_or("(unknown version)")
        )];
        if let Some(s) = &self.scene {
            parts.push(s.clone());
        }
        if let Some(n) = self.spp {
            parts.push(format!("{n} spp"));
        }
        match (&self.backend, &self.device) {
            (Some(b), Some(d)) => parts.push(format!("{b} on {d}")),
            (Some(b), None) => parts.push(b.clone()),
            _ => {}
        }
        parts.join(", ")
    }

    fn attributes(&self) -> HashMap<Text, AttributeValue> {
        let mut m = HashMap::new();
        let mut put = |name: &str, v: AttributeValue| {
            m.insert(text(&format!("{PREFIX}{name}")), v);
        };
        let int = |n: u32| match i32::try_from(n) {
            Ok(i) => AttributeValue::I32(i),
            Err(_) => AttributeValue::F64(n as f64),
        };
        let numbers = [
            ("spp", self.spp),
            ("sampleStart", self.samples.as_ref().map(|r| r.start)),
            ("sampleEnd", self.samples.as_ref().map(|r| r.end)),
            ("seed", self.seed),
            ("maxDepth", self.max_depth),
        ];
        for (name, v) in numbers {
            if let Some(n) = v {
                put(name, int(n));
            }
        }
        if let Some(s) = self.render_seconds {
            put("renderSeconds", AttributeValue::F64(s));
        }
        let texts = [
            ("sampler", &self.sampler),
            ("scene", &self.scene),
            ("sceneFileHash", &self.scene_file_hash),
            ("sceneHash", &self.scene_hash),
            ("version", &self.version),
            ("backend", &self.backend),
            ("device", &self.device),
        ];
        for (name, v) in texts {
            if let Some(s) = v {
                put(name, AttributeValue::Text(text(s)));
            }
        }
        if !self.overrides.is_empty() {
            put(
                "overrides",
                AttributeValue::TextVector(self.overrides.iter().map(|s| text(s)).collect()),
            );
        }
        m
    }

    /// The `brdfwave.*` attributes of a header; one of the wrong type is an error naming it.
    fn from_attributes(a: &HashMap<Text, AttributeValue>) -> Result<Provenance, String> {
        let get = |name: &str| a.get(&text(&format!("{PREFIX}{name}")));
        let number = |name: &str| -> Result<Option<f64>, String> {
            match get(name) {
                None => Ok(None),
                Some(AttributeValue::I32(i)) => Ok(Some(*i as f64)),
                Some(AttributeValue::F64(f)) => Ok(Some(*f)),
                Some(AttributeValue::F32(f)) => Ok(Some(*f as f64)),
                Some(_) => Err(format!("attribute {PREFIX}{name} is not a number")),
            }
        };
        let count = |name: &str| -> Result<Option<u32>, String> {
            match number(name)? {
                None => Ok(None),
                Some(f) if f >= 0.0 && f <= u32::MAX as f64 && f.fract() == 0.0 => {
                    Ok(Some(f as u32))
                }
                Some(f) => Err(format!(
                    "attribute {PREFIX}{name} = {f} is not a whole number from 0 to {}",
                    u32::MAX
                )),
            }
        };
        let string_of = |name: &str| -> Result<Option<String>, String> {
            match get(name) {
                None => Ok(None),
                Some(AttributeValue::Text(t)) => Ok(Some(string(t))),
                Some(_) => Err(format!("attribute {PREFIX}{name} is not a string")),
            }
        };
        let samples = match (count("sampleStart")?, count("sampleEnd")?) {
            (Some(s), Some(e)) if s <= e => Some(s..e),
            (None, None) => None,
            (s, e) => {
                return Err(format!(
                "attributes {PREFIX}sampleStart {s:?} and {PREFIX}sampleEnd {e:?} are not a range"
            ))
            }
        };
        let overrides = match get("overrides") {
            None => Vec::new(),
            Some(AttributeValue::TextVector(v)) => v.iter().map(string).collect(),
            Some(_) => return Err(format!("attribute {PREFIX}overrides is not a string list")),
        };
        Ok(Provenance {
            spp: count("spp")?,
            samples,
            seed: count("seed")?,
            sampler: string_of("sampler")?,
            max_depth: count("maxDepth")?,
            render_seconds: number("renderSeconds")?,
            scene: string_of("scene")?,
            scene_file_hash: string_of("sceneFileHash")?,
            scene_hash: string_of("sceneHash")?,
            overrides,
            version: string_of("version")?,
            backend: string_of("backend")?,
            device: string_of("device")?,
        })
    }
}

/// Checks every part's size against the film limit before anything is allocated.
fn check_headers(path: &Path) -> Result<exr::meta::MetaData, ImageError> {
    let meta = exr::meta::MetaData::read_from_buffered(BufReader::new(open(path)?), false)
        .map_err(|source| ImageError::Exr {
            path: path.to_path_buf(),
            source,
        })?;
    for header in &meta.headers {
        let size = header.layer_size;
        check_size(path, size.width() as u64, size.height() as u64)?;
    }
    Ok(meta)
}

/// An EXR file's colour image: its first part with `R`, `G` and `B` channels, else its first
/// with a luminance channel `Y` as grey (as Mitsuba 3 reads both).
pub(super) fn read_exr(path: &Path) -> Result<Image, ImageError> {
    use exr::prelude::{ReadChannels, ReadLayers, ReadSpecificChannel};
    // The headers first: the reader below allocates the image from the data window.
    let meta = check_headers(path)?;
    let has =
        |h: &exr::meta::header::Header, name: &str| h.channels.list.iter().any(|c| c.name.eq(name));
    let rgb = meta
        .headers
        .iter()
        .any(|h| ["R", "G", "B"].iter().all(|c| has(h, c)));
    let exr_error = |source| ImageError::Exr {
        path: path.to_path_buf(),
        source,
    };
    fn new(size: exr::math::Vec2<usize>) -> Image {
        Image::new(size.width() as u32, size.height() as u32)
    }
    fn at(img: &Image, pos: exr::math::Vec2<usize>) -> usize {
        pos.y() * img.width as usize + pos.x()
    }
    let reader = BufReader::new(open(path)?);
    if rgb {
        let exr_img = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .rgba_channels(
                |size, _| new(size),
                |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                    let i = at(img, pos);
                    img.data[i] = [r, g, b];
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(reader)
            .map_err(exr_error)?;
        return Ok(exr_img.layer_data.channel_data.pixels);
    }
    if !meta.headers.iter().any(|h| has(h, "Y")) {
        let names: Vec<String> = meta
            .headers
            .iter()
            .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
            .collect();
        return Err(ImageError::InvalidImage {
            path: path.to_path_buf(),
            reason: format!(
                "it has no R, G, B channels and no Y (luminance) channel, only: {}",
                crate::errors::excerpt(&names.join(", "))
            ),
        });
    }
    let exr_img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("Y")
        .collect_pixels(
            |size, _| new(size),
            |img: &mut Image, pos, (y,): (f32,)| {
                let i = at(img, pos);
                img.data[i] = [y; 3];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(reader)
        .map_err(exr_error)?;
    Ok(exr_img.layer_data.channel_data.pixels)
}

/// The first part of an EXR file: its `R`, `G`, `B` channels, its `variance.*` channels if
/// there are any (all three, or an error), and its `brdfwave.*` attributes.
pub(super) fn read_exr_layers(path: &Path) -> Result<Layered, ImageError> {
    use exr::prelude::{ReadChannels, ReadLayers};
    check_headers(path)?;
    let invalid = |reason: String| ImageError::InvalidImage {
        path: path.to_path_buf(),
        reason,
    };
    let exr_img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(BufReader::new(open(path)?))
        .map_err(|source| ImageError::Exr {
            path: path.to_path_buf(),
            source,
        })?;
    let layer = &exr_img.layer_data;
    let (w, h) = (layer.size.width() as u32, layer.size.height() as u32);
    let channels = &layer.channel_data.list;
    let find = |name: &str| {
        channels
            .iter()
            .find(|c| c.name.as_slice() == name.as_bytes())
    };
    let gather = |prefix: &str| -> Result<Option<Image>, ImageError> {
        let names = ["R", "G", "B"].map(|c| format!("{prefix}{c}"));
        let found = names.clone().map(|n| find(&n));
        if found.iter().all(Option::is_none) {
            return Ok(None);
        }
        let mut img = Image::new(w, h);
        for (c, ch) in found.iter().enumerate() {
            let ch = ch.ok_or_else(|| invalid(format!("it has no channel {}", names[c])))?;
            for (p, v) in img.data.iter_mut().zip(ch.sample_data.values_as_f32()) {
                p[c] = v;
            }
        }
        Ok(Some(img))
    };
    let image = gather("")?.ok_or_else(|| invalid("it has no R, G, B channels".into()))?;
    let variance = gather(&format!("{VARIANCE_LAYER}."))?;
    let provenance = Provenance::from_attributes(&layer.attributes.other).map_err(invalid)?;
    let batches_name = format!("{PREFIX}{BATCHES_ATTRIBUTE}");
    let batches = match layer.attributes.other.get(&text(&batches_name)) {
        None => None,
        Some(AttributeValue::I32(k)) if *k >= 2 => Some(*k as u32),
        Some(AttributeValue::I32(k)) => {
            return Err(invalid(format!(
                "attribute {batches_name} = {k}: a variance of the means takes at least 2 batches"
            )))
        }
        Some(_) => return Err(invalid(format!("attribute {batches_name} is not an int"))),
    };
    let batch_variance = match (gather(&format!("{MEAN_VARIANCE_LAYER}."))?, batches) {
        (Some(variance), Some(batches)) => Some(BatchVariance { variance, batches }),
        (None, None) => None,
        (Some(_), None) => {
            return Err(invalid(format!(
                "it has a {MEAN_VARIANCE_LAYER} layer but no attribute {batches_name}"
            )))
        }
        (None, Some(_)) => {
            return Err(invalid(format!(
                "it has the attribute {batches_name} but no {MEAN_VARIANCE_LAYER} layer"
            )))
        }
    };
    Ok(Layered {
        image,
        variance,
        batch_variance,
        provenance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn provenance() -> Provenance {
        Provenance {
            spp: Some(256),
            samples: Some(256..512),
            seed: Some(u32::MAX),
            sampler: Some("independent".into()),
            max_depth: Some(8),
            render_seconds: Some(1.25),
            scene: Some("scenes/kästchen.toml".into()),
            scene_file_hash: Some("0123456789abcdef".into()),
            scene_hash: Some("fedcba9876543210".into()),
            overrides: vec!["integrator.spp=256".into(), "materials.a.albedo=0.5".into()],
            version: Some("0.1.0+abc".into()),
            backend: Some("gpu".into()),
            device: Some("llvmpipe (LLVM 15.0.6, 256 bits)".into()),
        }
    }

    #[test]
    fn metadata_and_the_variance_layer_round_trip_and_plain_readers_see_the_image() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.exr");
        let img = Image::from_fn(5, 3, |x, y| [x as f32, y as f32, -0.5]);
        let var = Image::from_fn(5, 3, |x, y| [0.25 * x as f32, f32::INFINITY, y as f32]);
        let p = provenance();
        let extras = Extras {
            variance: Some(&var),
            provenance: Some(&p),
            ..Extras::default()
        };
        super::super::write_layered(&path, &img, &extras).unwrap();
        let back = super::super::read_layered(&path).unwrap();
        assert_eq!(back.image, img);
        assert_eq!(back.variance.as_ref(), Some(&var));
        assert_eq!(back.provenance, p);
        // A plain RGB reader gets the image.
        assert_eq!(super::super::read(&path).unwrap(), img);
        // The standard attributes.
        let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
        let own = &meta.headers[0].own_attributes;
        assert_eq!(
            own.comments.as_ref().map(string).as_deref(),
            Some(p.summary().as_str())
        );
        assert!(own.capture_date.is_some());
        // Without extras the file is the plain one, without attributes or layers.
        let plain = dir.path().join("plain.exr");
        super::super::write(&plain, &img).unwrap();
        let l = super::super::read_layered(&plain).unwrap();
        assert_eq!(
            (l.image, l.variance, l.provenance),
            (img.clone(), None, Provenance::default())
        );
        // A variance of the wrong size is refused.
        let small = Image::new(2, 2);
        let e = super::super::write_layered(
            &path,
            &img,
            &Extras {
                variance: Some(&small),
                ..Extras::default()
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("the variance is 2x2"), "{e}");
    }

    /// The variance of the means from batches travels as its own layer with the number of
    /// batches; a file with one and not the other, or fewer than 2 batches, is refused.
    #[test]
    fn the_batch_variance_layer_round_trips_with_its_count() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("batches.exr");
        let img = Image::from_fn(4, 3, |x, y| [x as f32, y as f32, 1.0]);
        let var = Image::from_fn(4, 3, |x, _| [x as f32; 3]);
        let mean_var = BatchVariance {
            variance: Image::from_fn(4, 3, |_, y| [0.5 * y as f32, 1e-9, 0.0]),
            batches: 8,
        };
        let p = provenance();
        let extras = Extras {
            variance: Some(&var),
            batch_variance: Some(&mean_var),
            provenance: Some(&p),
        };
        super::super::write_layered(&path, &img, &extras).unwrap();
        let back = super::super::read_layered(&path).unwrap();
        assert_eq!(
            (
                &back.image,
                back.variance.as_ref(),
                back.batch_variance.as_ref()
            ),
            (&img, Some(&var), Some(&mean_var))
        );
        assert_eq!(back.provenance, p);
        assert_eq!(super::super::read(&path).unwrap(), img);
        // Refused on writing: one batch, or the wrong size.
        for (bad, needle) in [
            (
                BatchVariance {
                    batches: 1,
                    ..mean_var.clone()
                },
                "at least 2",
            ),
            (
                BatchVariance {
                    variance: Image::new(2, 2),
                    batches: 4,
                },
                "variance of the means is 2x2",
            ),
        ] {
            let e = super::super::write_layered(
                &path,
                &img,
                &Extras {
                    batch_variance: Some(&bad),
                    ..Extras::default()
                },
            )
            .unwrap_err();
            assert!(e.to_string().contains(needle), "{e}");
        }
        // Refused on reading: the layer without its count, the count without the layer.
        let mut attributes = p.attributes();
        attributes.insert(text("brdfwave.batches"), AttributeValue::I32(4));
        let layer = |channels: &[&str], attributes: HashMap<Text, AttributeValue>| {
            use exr::prelude::{
                AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, SmallVec,
                WritableImage,
            };
            let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
                .iter()
                .map(|n| AnyChannel::new(*n, FlatSamples::F32(vec![0.5; 12])))
                .collect();
            let a = LayerAttributes {
                other: attributes,
                ..LayerAttributes::default()
            };
            let f = dir.path().join("hand.exr");
            exr::prelude::Image::from_layer(Layer::new(
                (4, 3),
                a,
                Encoding::SMALL_LOSSLESS,
                AnyChannels::sort(list),
            ))
            .write()
            .to_file(&f)
            .unwrap();
            super::super::read_layered(&f)
        };
        let rgb = ["R", "G", "B"];
        let e = layer(&rgb, attributes.clone()).unwrap_err().to_string();
        assert!(e.contains("no meanVariance layer"), "{e}");
        let with_layer = [
            &rgb[..],
            &["meanVariance.R", "meanVariance.G", "meanVariance.B"],
        ]
        .concat();
        let e = layer(&with_layer, p.attributes()).unwrap_err().to_string();
        assert!(e.contains("no attribute brdfwave.batches"), "{e}");
        attributes.insert(text("brdfwave.batches"), AttributeValue::I32(1));
        let e = layer(&with_layer, attributes.clone())
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 2 batches"), "{e}");
        attributes.insert(text("brdfwave.batches"), AttributeValue::I32(5));
        let l = layer(&with_layer, attributes).unwrap();
        assert_eq!(l.batch_variance.unwrap().batches, 5);
    }

    #[test]
    fn attributes_of_the_wrong_type_are_named() {
        let mut a = provenance().attributes();
        a.insert(text("brdfwave.spp"), AttributeValue::Text(text("many")));
        let e = Provenance::from_attributes(&a).unwrap_err();
        assert!(e.contains("brdfwave.spp is not a number"), "{e}");
        let mut a = provenance().attributes();
        a.insert(text("brdfwave.seed"), AttributeValue::F64(-1.0));
        assert!(Provenance::from_attributes(&a)
            .unwrap_err()
            .contains("brdfwave.seed"));
        let mut a = provenance().attributes();
        a.remove(&text("brdfwave.sampleEnd"));
        assert!(Provenance::from_attributes(&a)
            .unwrap_err()
            .contains("not a range"));
    }

    #[test]
    fn capture_dates_are_civil_utc() {
        let at = |s| capture_date(std::time::UNIX_EPOCH + std::time::Duration::from_secs(s));
        assert_eq!(at(0), "1970:01:01 00:00:00");
        // 2000-02-29 12:34:56 UTC, a leap day.
        assert_eq!(at(951_827_696), "2000:02:29 12:34:56");
        assert_eq!(at(1_796_083_199), "2026:11:30 23:59:59");
    }
}
