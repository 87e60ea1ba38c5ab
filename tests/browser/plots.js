// Every plot of the page as a person sees it: for each <svg> inside <main> that is
// shown, the problems of its text at screen size, one sentence each. arguments[0]: the
// smallest text size allowed, px.
//  * text smaller than that (font size × the figure's scale on screen);
//  * text cut by the figure's edge (its box leaves the <svg>'s box);
//  * two texts over each other (their boxes overlap by more than 1 px each way);
//  * text over data: a coloured (not grey) line, marker, bar or band edge crosses it.
const min = arguments[0];
const problems = [];
const coloured = (c) => {
  if (!c || c === "none") return false;
  const m = c.match(/^#([0-9a-f]{2})([0-9a-f]{2})([0-9a-f]{2})$/i);
  if (!m) return false;
  const v = m.slice(1).map((h) => parseInt(h, 16));
  return Math.max(...v) - Math.min(...v) > 40;
};
const inset = (r, d) => ({ l: r.left + d, r: r.right - d, t: r.top + d, b: r.bottom - d });
const inRect = (x, y, b) => x > b.l && x < b.r && y > b.t && y < b.b;
// Liang–Barsky: does the segment (x1,y1)–(x2,y2) cross the box b?
const hits = (x1, y1, x2, y2, b) => {
  let t0 = 0, t1 = 1;
  const dx = x2 - x1, dy = y2 - y1;
  for (const [p, q] of [[-dx, x1 - b.l], [dx, b.r - x1], [-dy, y1 - b.t], [dy, b.b - y1]]) {
    if (p === 0) { if (q < 0) return false; continue; }
    const t = q / p;
    if (p < 0) { if (t > t1) return false; if (t > t0) t0 = t; }
    else { if (t < t0) return false; if (t < t1) t1 = t; }
  }
  return true;
};
const screen = (el, x, y) => new DOMPoint(x, y).matrixTransform(el.getScreenCTM());
const dataHits = (el, b) => {
  const stroke = el.getAttribute("stroke"), fill = el.getAttribute("fill");
  if (!coloured(stroke) && !coloured(fill)) return false;
  const tag = el.tagName.toLowerCase();
  let pts = [];
  if (tag === "polyline" || tag === "polygon") {
    for (let i = 0; i < el.points.numberOfItems; i++) {
      const p = el.points.getItem(i);
      pts.push(screen(el, p.x, p.y));
    }
    if (tag === "polygon" && pts.length) pts.push(pts[0]);
  } else if (tag === "line") {
    const a = (n) => parseFloat(el.getAttribute(n));
    pts = [screen(el, a("x1"), a("y1")), screen(el, a("x2"), a("y2"))];
  } else if (tag === "circle" || tag === "rect") {
    const r = el.getBoundingClientRect();
    return r.right > b.l && r.left < b.r && r.bottom > b.t && r.top < b.b;
  } else {
    return false;
  }
  if (pts.length === 1) return inRect(pts[0].x, pts[0].y, b);
  for (let i = 1; i < pts.length; i++) {
    if (hits(pts[i - 1].x, pts[i - 1].y, pts[i].x, pts[i].y, b)) return true;
  }
  return false;
};
document.querySelectorAll("main svg").forEach((svg) => {
  const box = svg.getBoundingClientRect();
  if (box.width < 1 || box.height < 1) return;
  const texts = [...svg.querySelectorAll("text")].filter((t) => t.textContent.trim() !== "");
  if (!texts.length) return;
  const holder = svg.closest("[id], [data-plot], [data-term]");
  const name = `${holder ? holder.id || holder.dataset.plot || holder.dataset.term : "?"} ` +
    `«${texts[0].textContent.trim()}»`;
  const data = [...svg.querySelectorAll("polyline, polygon, line, circle, rect")];
  const boxes = texts.map((t) => {
    const m = t.getScreenCTM();
    const px = parseFloat(getComputedStyle(t).fontSize) * Math.hypot(m.a, m.b);
    return { text: t.textContent.trim(), px, r: t.getBoundingClientRect() };
  });
  boxes.forEach((a, i) => {
    if (a.px < min - 0.05) {
      problems.push(`${name}: «${a.text}» is ${a.px.toFixed(1)} px`);
    }
    const r = a.r;
    if (r.left < box.left - 0.5 || r.right > box.right + 0.5 ||
        r.top < box.top - 0.5 || r.bottom > box.bottom + 0.5) {
      problems.push(`${name}: «${a.text}» is cut by the figure's edge`);
    }
    for (const b of boxes.slice(i + 1)) {
      const w = Math.min(r.right, b.r.right) - Math.max(r.left, b.r.left);
      const h = Math.min(r.bottom, b.r.bottom) - Math.max(r.top, b.r.top);
      if (w > 1 && h > 1) problems.push(`${name}: «${a.text}» overlaps «${b.text}»`);
    }
    const inner = inset(r, 1);
    if (data.some((el) => dataHits(el, inner))) {
      problems.push(`${name}: «${a.text}» lies over the data`);
    }
  });
});
return problems;
