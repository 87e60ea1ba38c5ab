//! Reading a plot back from its SVG, for tests (here, in the server and in the browser
//! tests): the marks (circles, lines, polylines, polygons, rectangles, text) with their
//! pixel coordinates and colours, and the axes recovered from the tick labels alone.
//!
//! The axes are the least-squares line through (tick value, tick pixel) of the numeric
//! (or `YYYY-MM-DD`, as Unix seconds) labels: x labels are the centred (`middle`) ones on
//! the most common baseline, y labels the right-aligned (`end`) ones on the most common
//! x. A test then checks that a mark sits where its datum says — an independent check of
//! the drawing, since the labels are written by the axis code and the marks by the series
//! code.

use std::collections::BTreeMap;

/// A colour as written by plotters: `#RRGGBB`.
pub fn hex(c: plotters::style::RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

#[derive(Debug, Clone, PartialEq)]
pub struct Text {
    pub x: f64,
    pub y: f64,
    /// `start`, `middle` or `end`.
    pub anchor: String,
    pub content: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    /// `circle`, `line`, `polyline`, `polygon` or `rect`.
    pub tag: String,
    /// Points: a circle's centre; a line's two ends; a rectangle's corners (top left,
    /// bottom right).
    pub points: Vec<(f64, f64)>,
    /// Circle radius (0 for other marks).
    pub r: f64,
    pub stroke: Option<String>,
    pub fill: Option<String>,
    pub opacity: f64,
}

/// Every mark and text of one `<svg>`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plot {
    pub width: f64,
    pub height: f64,
    pub marks: Vec<Mark>,
    pub texts: Vec<Text>,
}

/// px = offset + scale · value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linear {
    pub offset: f64,
    pub scale: f64,
}

impl Linear {
    pub fn px(&self, value: f64) -> f64 {
        self.offset + self.scale * value
    }
    pub fn value(&self, px: f64) -> f64 {
        (px - self.offset) / self.scale
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axes {
    pub x: Linear,
    pub y: Linear,
}

impl Axes {
    /// Data coordinates of a pixel.
    pub fn data(&self, p: (f64, f64)) -> (f64, f64) {
        (self.x.value(p.0), self.y.value(p.1))
    }
}

fn num(n: &roxmltree::Node, a: &str) -> f64 {
    n.attribute(a)
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0.0)
}

fn points(s: &str) -> Vec<(f64, f64)> {
    s.split_whitespace()
        .filter_map(|p| {
            let (x, y) = p.split_once(',')?;
            Some((x.parse().ok()?, y.parse().ok()?))
        })
        .collect()
}

/// Parses the first `<svg>` element of `text` (a whole page may be given).
pub fn parse(text: &str) -> Result<Plot, String> {
    let start = text.find("<svg").ok_or("no <svg> element")?;
    let end = text[start..].find("</svg>").ok_or("unterminated <svg>")? + start + 6;
    let doc = roxmltree::Document::parse(&text[start..end]).map_err(|e| e.to_string())?;
    let root = doc.root_element();
    let mut plot = Plot {
        width: num(&root, "width"),
        height: num(&root, "height"),
        ..Plot::default()
    };
    for n in root.descendants().filter(|n| n.is_element()) {
        let tag = n.tag_name().name();
        let colour = |a: &str| n.attribute(a).filter(|v| *v != "none").map(str::to_string);
        let pts = match tag {
            "circle" => vec![(num(&n, "cx"), num(&n, "cy"))],
            "line" => vec![
                (num(&n, "x1"), num(&n, "y1")),
                (num(&n, "x2"), num(&n, "y2")),
            ],
            "polyline" | "polygon" => points(n.attribute("points").unwrap_or("")),
            "rect" => {
                let (x, y) = (num(&n, "x"), num(&n, "y"));
                vec![(x, y), (x + num(&n, "width"), y + num(&n, "height"))]
            }
            "text" => {
                plot.texts.push(Text {
                    x: num(&n, "x"),
                    y: num(&n, "y"),
                    anchor: n.attribute("text-anchor").unwrap_or("start").into(),
                    content: n
                        .descendants()
                        .filter(|c| c.is_text())
                        .filter_map(|c| c.text())
                        .collect::<String>()
                        .trim()
                        .to_string(),
                });
                continue;
            }
            _ => continue,
        };
        plot.marks.push(Mark {
            tag: tag.into(),
            points: pts,
            r: num(&n, "r"),
            stroke: colour("stroke"),
            fill: colour("fill"),
            opacity: n
                .attribute("opacity")
                .and_then(|v| v.parse().ok())
                .unwrap_or(1.0),
        });
    }
    Ok(plot)
}

/// A tick label's value: a number, or a date `YYYY-MM-DD` (optionally ` HH:MM`) as Unix
/// seconds.
pub fn label_value(s: &str) -> Option<f64> {
    if let Ok(v) = s.parse::<f64>() {
        return v.is_finite().then_some(v);
    }
    let (day, hm) = s.split_once(' ').unwrap_or((s, "00:00"));
    let date = time::Date::parse(
        day,
        &time::macros::format_description!("[year]-[month]-[day]"),
    )
    .ok()?;
    let t = time::Time::parse(hm, &time::macros::format_description!("[hour]:[minute]")).ok()?;
    Some(date.with_time(t).assume_utc().unix_timestamp() as f64)
}

fn fit(pairs: &[(f64, f64)], axis: &str) -> Result<Linear, String> {
    if pairs.len() < 2 {
        return Err(format!("{axis}: fewer than two tick labels"));
    }
    let n = pairs.len() as f64;
    let mv = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let mp = pairs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pairs.iter().map(|p| (p.0 - mv).powi(2)).sum();
    let sxy: f64 = pairs.iter().map(|p| (p.0 - mv) * (p.1 - mp)).sum();
    if sxx == 0.0 {
        return Err(format!("{axis}: tick labels all equal"));
    }
    let scale = sxy / sxx;
    let l = Linear {
        offset: mp - scale * mv,
        scale,
    };
    // Pixels are integers: a label may be off by half a pixel.
    let worst = pairs
        .iter()
        .map(|p| (l.px(p.0) - p.1).abs())
        .fold(0.0, f64::max);
    if worst > 1.5 {
        return Err(format!(
            "{axis}: tick labels not evenly spaced ({worst} px off)"
        ));
    }
    Ok(l)
}

/// The most common value of `key` among `texts` (rounded to a pixel).
fn mode(texts: &[&Text], key: impl Fn(&Text) -> f64) -> Option<i64> {
    let mut counts: BTreeMap<i64, usize> = BTreeMap::new();
    for t in texts {
        *counts.entry(key(t).round() as i64).or_default() += 1;
    }
    counts.into_iter().max_by_key(|&(_, c)| c).map(|(k, _)| k)
}

impl Plot {
    /// The x axis from its tick labels (module docs).
    pub fn x_axis(&self) -> Result<Linear, String> {
        self.axis("middle", "x")
    }

    /// The y axis from its tick labels (module docs).
    pub fn y_axis(&self) -> Result<Linear, String> {
        self.axis("end", "y")
    }

    /// Both axes.
    pub fn axes(&self) -> Result<Axes, String> {
        Ok(Axes {
            x: self.x_axis()?,
            y: self.y_axis()?,
        })
    }

    fn axis(&self, anchor: &str, name: &str) -> Result<Linear, String> {
        let ticks: Vec<&Text> = self
            .texts
            .iter()
            .filter(|t| t.anchor == anchor && label_value(&t.content).is_some())
            .collect();
        // x labels share a baseline, y labels a right edge.
        let across = |t: &Text| if name == "x" { t.y } else { t.x };
        let along = |t: &Text| if name == "x" { t.x } else { t.y };
        let line = mode(&ticks, across).ok_or(format!("no {name} tick labels"))?;
        let pairs: Vec<(f64, f64)> = ticks
            .iter()
            .filter(|t| across(t).round() as i64 == line)
            .map(|t| (label_value(&t.content).unwrap_or(f64::NAN), along(t)))
            .collect();
        fit(&pairs, name)
    }

    /// Marks of one tag whose stroke or fill is `colour` (`#RRGGBB`).
    pub fn marks(&self, tag: &str, colour: &str) -> Vec<&Mark> {
        self.marks
            .iter()
            .filter(|m| {
                m.tag == tag
                    && (m.stroke.as_deref() == Some(colour) || m.fill.as_deref() == Some(colour))
            })
            .collect()
    }

    /// Whether any text contains `s`.
    pub fn has_text(&self, s: &str) -> bool {
        self.texts.iter().any(|t| t.content.contains(s))
    }
}
