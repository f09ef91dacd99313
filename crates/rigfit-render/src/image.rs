//! [`Image`]: an RGBA picture with text, blitting and PNG encoding.

use font8x8::UnicodeFonts;
use tiny_skia::{Pixmap, PixmapPaint, Transform};

use crate::color::Color;

/// The largest side of any picture, in pixels.
pub const MAX_SIDE: u32 = 8192;

/// Why a picture could not be encoded.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("PNG encoding failed: {0}")]
    Png(String),
    #[error("not a PNG picture rigfit can read: {0}")]
    Decode(String),
}

/// An opaque RGBA picture (a `tiny_skia::Pixmap`).
#[derive(Clone, Debug)]
pub struct Image {
    pub(crate) pixmap: Pixmap,
}

impl Image {
    /// A picture filled with `background`; sides are clamped to `1..=MAX_SIDE`.
    pub fn new(width: u32, height: u32, background: Color) -> Self {
        let mut pixmap = Pixmap::new(width.clamp(1, MAX_SIDE), height.clamp(1, MAX_SIDE))
            .expect("sides clamped to 1..=8192 fit a pixmap");
        pixmap.fill(background.to_skia());
        Self { pixmap }
    }

    pub fn width(&self) -> u32 {
        self.pixmap.width()
    }

    pub fn height(&self) -> u32 {
        self.pixmap.height()
    }

    /// The colour at a pixel (`None` outside the picture).
    pub fn pixel(&self, x: u32, y: u32) -> Option<Color> {
        let p = self.pixmap.pixel(x, y)?.demultiply();
        Some(Color::rgb(p.red(), p.green(), p.blue()))
    }

    /// The picture as PNG bytes.
    pub fn png(&self) -> Result<Vec<u8>, RenderError> {
        self.pixmap
            .encode_png()
            .map_err(|e| RenderError::Png(e.to_string()))
    }

    /// Reads PNG bytes (for tests that look at written pictures).
    pub fn from_png(bytes: &[u8]) -> Result<Self, RenderError> {
        Pixmap::decode_png(bytes)
            .map(|pixmap| Self { pixmap })
            .map_err(|e| RenderError::Decode(e.to_string()))
    }

    /// Copies `other` with its top-left corner at `(x, y)`.
    pub fn blit(&mut self, other: &Image, x: i32, y: i32) {
        self.pixmap.draw_pixmap(
            x,
            y,
            other.pixmap.as_ref(),
            &PixmapPaint::default(),
            Transform::identity(),
            None,
        );
    }

    /// Pictures one above the other, left-aligned, on `background`.
    pub fn stack_vertical(images: &[Image], background: Color) -> Image {
        let width = images.iter().map(Image::width).max().unwrap_or(1);
        let height = images.iter().map(Image::height).sum::<u32>();
        let mut out = Image::new(width, height, background);
        let mut y = 0;
        for image in images {
            out.blit(image, 0, y as i32);
            y += image.height();
        }
        out
    }

    /// Pictures side by side, top-aligned, on `background`.
    pub fn stack_horizontal(images: &[Image], background: Color) -> Image {
        let width = images.iter().map(Image::width).sum::<u32>();
        let height = images.iter().map(Image::height).max().unwrap_or(1);
        let mut out = Image::new(width, height, background);
        let mut x = 0;
        for image in images {
            out.blit(image, x as i32, 0);
            x += image.width();
        }
        out
    }

    /// Sets the pixels of an axis-aligned rectangle (clipped), no blending.
    pub(crate) fn fill_pixels(&mut self, x: i64, y: i64, w: i64, h: i64, color: Color) {
        let (width, height) = (self.width() as i64, self.height() as i64);
        let (x0, y0) = (x.max(0), y.max(0));
        let (x1, y1) = ((x + w).min(width), (y + h).min(height));
        if x0 >= x1 || y0 >= y1 {
            return;
        }
        let data = self.pixmap.data_mut();
        let rgba = [color.r, color.g, color.b, 255];
        for row in y0..y1 {
            let start = ((row * width + x0) * 4) as usize;
            let end = ((row * width + x1) * 4) as usize;
            for px in data[start..end].chunks_exact_mut(4) {
                px.copy_from_slice(&rgba);
            }
        }
    }

    /// Draws `text` (ASCII; other characters show as `?`) with its top-left corner at
    /// `(x, y)`, each font pixel `scale` pixels wide. Returns the width drawn.
    pub(crate) fn text(&mut self, x: i64, y: i64, text: &str, scale: u32, color: Color) -> i64 {
        let s = scale.max(1) as i64;
        let mut cx = x;
        for c in text.chars() {
            let glyph = font8x8::BASIC_FONTS
                .get(c)
                .or_else(|| font8x8::BASIC_FONTS.get('?'))
                .unwrap_or([0; 8]);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        self.fill_pixels(cx + col * s, y + row as i64 * s, s, s, color);
                    }
                }
            }
            cx += text_advance(scale);
        }
        cx - x
    }
}

/// The horizontal advance of one character at `scale`.
pub(crate) fn text_advance(scale: u32) -> i64 {
    8 * scale.max(1) as i64
}

/// The width of `text` at `scale`.
pub(crate) fn text_width(text: &str, scale: u32) -> i64 {
    text.chars().count() as i64 * text_advance(scale)
}
