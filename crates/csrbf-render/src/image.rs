//! RGBA pictures and PNG files.

use std::path::Path;

use crate::{RenderError, Result};

/// An RGBA8 picture (sRGB), rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels, 4 bytes each.
    pub rgba: Vec<u8>,
}

impl Image {
    /// The pixel at (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = 4 * (y as usize * self.width as usize + x as usize);
        [
            self.rgba[i],
            self.rgba[i + 1],
            self.rgba[i + 2],
            self.rgba[i + 3],
        ]
    }

    /// PNG-encoded bytes.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width, self.height);
            enc.set_color(png::ColorType::Rgba);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_compression(png::Compression::Fast);
            let mut w = enc
                .write_header()
                .map_err(|e| RenderError::Encode(e.to_string()))?;
            w.write_image_data(&self.rgba)
                .map_err(|e| RenderError::Encode(e.to_string()))?;
        }
        Ok(out)
    }

    /// Writes a PNG file whole or not at all.
    pub fn save_png(&self, path: &Path) -> Result<()> {
        crate::movie::write_whole(path, &self.to_png()?)
    }
}
