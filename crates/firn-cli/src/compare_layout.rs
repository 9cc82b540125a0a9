//! Where everything goes in `firn compare`'s picture: a header row of time
//! labels, a left column of scene labels, and one panel per (scene, time),
//! all separated by thin gutters. Pure arithmetic, so it is tested alone.

use firn_render::legend::{text_scale, text_width};
use serde::Serialize;

/// Height in pixels of the bitmap font at scale 1.
pub const GLYPH_PIXELS: u32 = 8;
/// Gutter width in font pixels (scaled with the text).
const GUTTER_FONT_PIXELS: u32 = 4;

/// A rectangle of the picture, in pixels from its top-left corner.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Rect {
    /// Left edge.
    pub x: u32,
    /// Top edge.
    pub y: u32,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
}

/// What decides the grid: its shape, the panel size and the text sizes.
#[derive(Clone, Copy, Debug)]
pub struct GridSpec {
    /// Rows (scenes).
    pub rows: u32,
    /// Columns (times).
    pub columns: u32,
    /// Width and height of one panel.
    pub panel: [u32; 2],
    /// Width of the widest row label.
    pub label_width: u32,
    /// Width of the widest column header.
    pub header_width: u32,
    /// Height of a line of text.
    pub text_height: u32,
    /// Space between panels and around the edges.
    pub gutter: u32,
}

/// The rectangles of the whole picture.
#[derive(Debug, Serialize)]
pub struct Layout {
    /// Width of the picture.
    pub width: u32,
    /// Height of the picture.
    pub height: u32,
    /// Panels, one list per row, one rectangle per column.
    pub panels: Vec<Vec<Rect>>,
    /// Header cells above the columns (text is centred in them).
    pub headers: Vec<Rect>,
    /// Label cells left of the rows (text is left-aligned and centred vertically).
    pub labels: Vec<Rect>,
}

/// Lays out the grid. Each cell is as wide as the wider of a panel and the
/// widest header, and as tall as the taller of a panel and a line of text;
/// panels sit centred in their cells.
pub fn grid_layout(spec: &GridSpec) -> Layout {
    let gutter = spec.gutter;
    let [panel_width, panel_height] = spec.panel;
    let cell_width = panel_width.max(spec.header_width);
    let cell_height = panel_height.max(spec.text_height);
    let left = gutter + spec.label_width + gutter;
    let top = gutter + spec.text_height + gutter;
    let cell_x = |column: u32| left + column * (cell_width + gutter);
    let cell_y = |row: u32| top + row * (cell_height + gutter);
    let panels = (0..spec.rows)
        .map(|row| {
            (0..spec.columns)
                .map(|column| Rect {
                    x: cell_x(column) + (cell_width - panel_width) / 2,
                    y: cell_y(row) + (cell_height - panel_height) / 2,
                    width: panel_width,
                    height: panel_height,
                })
                .collect()
        })
        .collect();
    let headers = (0..spec.columns)
        .map(|column| Rect {
            x: cell_x(column),
            y: gutter,
            width: cell_width,
            height: spec.text_height,
        })
        .collect();
    let labels = (0..spec.rows)
        .map(|row| Rect {
            x: gutter,
            y: cell_y(row),
            width: spec.label_width,
            height: cell_height,
        })
        .collect();
    Layout {
        width: cell_x(spec.columns),
        height: cell_y(spec.rows),
        panels,
        headers,
        labels,
    }
}

/// The grid for `labels` (one per row) and `headers` (one per column) over
/// panels of `panel` pixels, with text at [`label_scale`]; returns the
/// layout and the text scale.
pub fn layout_for(labels: &[String], headers: &[String], panel: [u32; 2]) -> (Layout, u32) {
    let scale = label_scale(headers, panel);
    let widest = |texts: &[String]| {
        texts
            .iter()
            .map(|text| text_width(text, scale))
            .max()
            .unwrap_or(0)
    };
    let gutter = GUTTER_FONT_PIXELS * scale;
    let spec = GridSpec {
        rows: labels.len() as u32,
        columns: headers.len() as u32,
        panel,
        label_width: widest(labels),
        // Headers wider than a panel keep a gutter between neighbours.
        header_width: widest(headers) + gutter,
        text_height: GLYPH_PIXELS * scale,
        gutter,
    };
    (grid_layout(&spec), scale)
}

/// Font scale of the labels: twice that of the legend inside a panel, made
/// smaller (down to 1) until every header fits over its panel.
pub fn label_scale(headers: &[String], panel: [u32; 2]) -> u32 {
    let fits = |scale: u32| {
        headers
            .iter()
            .all(|text| text_width(text, scale) <= panel[0])
    };
    let mut scale = 2 * text_scale(panel[1]);
    while scale > 1 && !fits(scale) {
        scale -= 1;
    }
    scale
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> GridSpec {
        GridSpec {
            rows: 2,
            columns: 3,
            panel: [64, 48],
            label_width: 40,
            header_width: 50,
            text_height: 8,
            gutter: 4,
        }
    }

    #[test]
    fn panels_follow_labels_and_headers_with_gutters_between() {
        let layout = grid_layout(&spec());
        // 4 + 40 + 4 on the left, then three 64-pixel columns each followed by 4.
        assert_eq!(layout.width, 48 + 3 * 68);
        // 4 + 8 + 4 on top, then two 48-pixel rows each followed by 4.
        assert_eq!(layout.height, 16 + 2 * 52);
        assert_eq!(
            layout.panels[0][0],
            Rect {
                x: 48,
                y: 16,
                width: 64,
                height: 48
            }
        );
        assert_eq!(layout.panels[1][2].x, 48 + 2 * 68);
        assert_eq!(layout.panels[1][2].y, 16 + 52);
        assert_eq!(layout.headers[2].x, layout.panels[0][2].x);
        assert_eq!(layout.headers[2].y + layout.headers[2].height, 12);
        assert_eq!(layout.labels[1].y, layout.panels[1][0].y);
        assert_eq!(layout.labels[1].x + layout.labels[1].width + 4, 48);
    }

    #[test]
    fn nothing_overlaps_and_everything_fits_inside() {
        let layout = grid_layout(&spec());
        let mut rects: Vec<Rect> = layout.panels.iter().flatten().copied().collect();
        rects.extend(&layout.headers);
        rects.extend(&layout.labels);
        for (i, a) in rects.iter().enumerate() {
            assert!(a.x + a.width <= layout.width && a.y + a.height <= layout.height);
            for b in &rects[i + 1..] {
                let apart = a.x + a.width <= b.x
                    || b.x + b.width <= a.x
                    || a.y + a.height <= b.y
                    || b.y + b.height <= a.y;
                assert!(apart, "{a:?} overlaps {b:?}");
            }
        }
    }

    #[test]
    fn wide_headers_widen_the_cells_and_centre_the_panels() {
        let layout = grid_layout(&GridSpec {
            header_width: 80,
            ..spec()
        });
        assert_eq!(layout.headers[0].width, 80);
        assert_eq!(layout.panels[0][0].x, layout.headers[0].x + 8);
        assert_eq!(layout.panels[0][1].x, layout.headers[1].x + 8);
        assert_eq!(layout.width, 48 + 3 * 84);
    }

    #[test]
    fn text_is_larger_on_large_panels_but_headers_still_fit() {
        let headers = vec!["t = 0.901 s".to_string(), "t = 4.054 s".to_string()];
        assert_eq!(label_scale(&headers, [480, 270]), 2);
        assert_eq!(label_scale(&headers, [1920, 1080]), 6);
        // 11 characters of 8 pixels do not fit over 64 pixels at any scale.
        assert_eq!(label_scale(&headers, [64, 48]), 1);
        assert_eq!(label_scale(&headers, [100, 1080]), 1);
    }

    #[test]
    fn the_layout_is_sized_from_the_texts() {
        let labels = vec!["soft".to_string(), "hard snow".to_string()];
        let headers = vec!["t = 0.1 s".to_string(); 3];
        let (layout, scale) = layout_for(&labels, &headers, [480, 270]);
        assert_eq!(scale, 2);
        assert_eq!(layout.labels[0].width, 9 * 16);
        assert_eq!(layout.headers[0].height, 16);
        assert_eq!(layout.panels.len(), 2);
        assert_eq!(layout.panels[0].len(), 3);
        assert_eq!(layout.width, 8 + 9 * 16 + 8 + 3 * (480 + 8));
        // Over small panels, headers set the column width and keep apart.
        let (layout, scale) = layout_for(&labels, &headers, [64, 48]);
        assert_eq!(scale, 1);
        assert_eq!(layout.headers[0].width, 9 * 8 + 4);
        assert_eq!(layout.headers[1].x - layout.headers[0].x, 9 * 8 + 4 + 4);
    }
}
