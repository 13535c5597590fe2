//! The film: named layers of interleaved float channels.

/// A rendered image: named layers (beauty and AOVs), all of the same size.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The layers, in the order they were added (or, for a film read from a file, beauty first and
    /// then the others in alphabetical order).
    pub layers: Vec<Layer>,
    /// Width over height of a pixel (EXR `pixelAspectRatio`; 1: square).
    pub pixel_aspect: f32,
}

/// One layer of a [`Film`]: a set of float channels stored interleaved.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// Layer name; `""` is the beauty layer. In an EXR file channel `C` of layer `L` is called `L.C`
    /// (beauty channels are just `C`).
    pub name: String,
    /// Channel names, e.g. `["R", "G", "B", "A"]` or `["Z"]`; never empty and without dots.
    pub channels: Vec<String>,
    /// `width · height · channels.len()` values: row-major, top row first, channels interleaved.
    pub data: Vec<f32>,
}

impl Layer {
    /// Index of channel `name` within a pixel, if the layer has it.
    pub fn channel_index(&self, name: &str) -> Option<usize> {
        self.channels.iter().position(|c| c == name)
    }

    /// The values of pixel `index` (`y · width + x`), one per channel.
    ///
    /// # Panics
    /// If `index` is outside the layer.
    pub fn pixel(&self, index: usize) -> &[f32] {
        let n = self.channels.len();
        &self.data[index * n..(index + 1) * n]
    }

    /// Mutable access to the values of pixel `index` (`y · width + x`).
    ///
    /// # Panics
    /// If `index` is outside the layer.
    pub fn pixel_mut(&mut self, index: usize) -> &mut [f32] {
        let n = self.channels.len();
        &mut self.data[index * n..(index + 1) * n]
    }
}

impl Film {
    /// An empty film (no layers) of the given size.
    pub fn new(width: u32, height: u32) -> Film {
        Film { width, height, layers: Vec::new(), pixel_aspect: 1.0 }
    }

    /// Number of pixels (`width · height`).
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Add a zero-filled layer and return its index in [`Film::layers`]. A layer of the same name
    /// is replaced (keeping its position).
    ///
    /// # Panics
    /// If `channels` is empty, or a channel name is empty, contains a dot or is repeated: such a
    /// layer could not be written to or read back from an EXR file, so this is a programming error.
    pub fn add_layer(&mut self, name: &str, channels: &[&str]) -> usize {
        let data = vec![0.0; self.pixel_count() * channels.len()];
        self.insert_layer(name, channels, data)
    }

    /// [`Film::add_layer`], allocated fallibly: [`crate::Error::OutOfMemory`] when the layer does
    /// not fit in memory (a render's film).
    pub fn try_add_layer(&mut self, name: &str, channels: &[&str]) -> crate::Result<usize> {
        let (w, h) = (self.width, self.height);
        let data = crate::memory::try_vec(self.pixel_count() * channels.len(), 0.0, || format!("the {w}x{h} film's layer {name:?}"))?;
        Ok(self.insert_layer(name, channels, data))
    }

    fn insert_layer(&mut self, name: &str, channels: &[&str], data: Vec<f32>) -> usize {
        assert!(!channels.is_empty(), "layer {name:?} needs at least one channel");
        for (i, c) in channels.iter().enumerate() {
            assert!(!c.is_empty() && !c.contains('.'), "layer {name:?}: invalid channel name {c:?}");
            assert!(!channels[..i].contains(c), "layer {name:?}: channel {c:?} given twice");
        }
        let layer = Layer {
            name: name.to_string(),
            channels: channels.iter().map(|c| c.to_string()).collect(),
            data,
        };
        match self.layers.iter().position(|l| l.name == name) {
            Some(i) => {
                self.layers[i] = layer;
                i
            }
            None => {
                self.layers.push(layer);
                self.layers.len() - 1
            }
        }
    }

    /// The layer called `name` (`""` = beauty).
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        self.layers.iter().find(|l| l.name == name)
    }

    /// Mutable access to the layer called `name` (`""` = beauty).
    pub fn layer_mut(&mut self, name: &str) -> Option<&mut Layer> {
        self.layers.iter_mut().find(|l| l.name == name)
    }

    /// The R, G and B channels of layer `name` as an RGB buffer (3 floats per pixel, top row
    /// first); `None` if there is no such layer or it lacks one of R, G, B.
    pub fn rgb(&self, name: &str) -> Option<Vec<f32>> {
        let layer = self.layer(name)?;
        let idx = [layer.channel_index("R")?, layer.channel_index("G")?, layer.channel_index("B")?];
        let n = layer.channels.len();
        let mut out = Vec::with_capacity(self.pixel_count() * 3);
        for px in layer.data.chunks_exact(n) {
            out.extend(idx.iter().map(|&i| px[i]));
        }
        Some(out)
    }

    /// Multiply the radiance of the image — the R, G, B channels of the beauty layer and of the
    /// `direct` and `indirect` layers — by `k` (a camera's exposure); alpha and the other AOVs
    /// (albedo, normal, depth) stay. `k = 1` leaves every value as it is.
    pub fn scale_radiance(&mut self, k: f32) {
        if k == 1.0 {
            return;
        }
        for name in ["", "direct", "indirect"] {
            let Some(layer) = self.layer_mut(name) else { continue };
            let idx: Vec<usize> = ["R", "G", "B"].iter().filter_map(|c| layer.channel_index(c)).collect();
            let n = layer.channels.len();
            for px in layer.data.chunks_exact_mut(n) {
                idx.iter().for_each(|&i| px[i] *= k);
            }
        }
    }

    /// Number of NaN or infinite values over all channels of all layers.
    pub fn nan_count(&self) -> usize {
        self.layers.iter().map(|l| l.data.iter().filter(|v| !v.is_finite()).count()).sum()
    }
}
