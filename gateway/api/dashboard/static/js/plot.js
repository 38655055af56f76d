// A live position plot per axis (uPlot: one canvas, no DOM per point), with the target and the
// soft limits drawn as horizontal lines. The plot reads the axis's history from the store and
// is redrawn at most once a frame, whatever the update rate.

import { html, useEffect, useRef } from "../vendor/preact-htm/standalone.module.js";
import uPlot from "../vendor/uplot/uPlot.esm.js";
import { HISTORY_SECONDS, store, subscribe } from "./store.js";

const COLORS = { position: "#4cc2ff", target: "#ffb347", limit: "#e5534b" };

function lines(u, values, color, dash) {
  const { ctx } = u;
  ctx.save();
  ctx.strokeStyle = color;
  ctx.lineWidth = 1.5 * devicePixelRatio;
  ctx.setLineDash(dash.map((d) => d * devicePixelRatio));
  for (const v of values) {
    if (v == null) continue;
    const y = Math.round(u.valToPos(v, "y", true));
    if (y < u.bbox.top || y > u.bbox.top + u.bbox.height) continue;
    ctx.beginPath();
    ctx.moveTo(u.bbox.left, y);
    ctx.lineTo(u.bbox.left + u.bbox.width, y);
    ctx.stroke();
  }
  ctx.restore();
}

// A step of 1, 2 or 5 times a power of ten, about `span / count`.
function niceStep(span, count) {
  const rough = span / Math.max(count, 1);
  const power = 10 ** Math.floor(Math.log10(rough));
  const m = rough / power;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * power;
}

// The y scale's ticks: round values a step apart, as many as the plot's height has room for
// (one every 28 px, at least two), so every label is one of several and none is mistaken
// for the value.
function yTicks(u, min, max) {
  const room = Math.max(2, Math.floor(u.bbox.height / devicePixelRatio / 28));
  const step = niceStep(max - min, room);
  const out = [];
  for (let v = Math.ceil(min / step) * step; v <= max + step * 1e-9; v += step) out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return { step, values: out };
}

// Digits enough to tell two ticks `step` apart, no more.
const tickDigits = (step) => Math.max(0, Math.min(6, -Math.floor(Math.log10(step) + 1e-9)));

// `every`: the shortest time between two redraws (ms); a plot out of view is not redrawn.
export function PositionPlot({ axisId, height = 120, window = HISTORY_SECONDS, every = 50 }) {
  const box = useRef(null);
  useEffect(() => {
    const el = box.current;
    const marks = () => {
      const axis = store.axes.get(axisId) || {};
      const op = store.ops.get(axisId);
      const live = op && !["done", "failed", "unknown"].includes(op.state);
      return { axis, target: live ? (op.target_user ?? op.target) : null };
    };
    const measured = { key: "", size: 40 };
    const opts = {
      width: el.clientWidth || 300,
      height,
      legend: { show: false },
      cursor: { show: false },
      scales: {
        x: { time: true },
        y: {
          // The data and the target; a soft limit only when the data comes near it (the
          // limit bar shows where the axis is in its whole stroke).
          range: (u, min, max) => {
            const { axis, target } = marks();
            const vals = [min, max, target].filter((v) => v != null && isFinite(v));
            let lo = Math.min(...vals);
            let hi = Math.max(...vals);
            const span = Math.max(hi - lo, 1);
            for (const limit of [axis.soft_min, axis.soft_max]) {
              if (limit != null && limit > lo - span * 0.5 && limit < hi + span * 0.5) {
                lo = Math.min(lo, limit);
                hi = Math.max(hi, limit);
              }
            }
            if (hi - lo < 1e-9) {
              lo -= 1;
              hi += 1;
            }
            const pad = (hi - lo) * 0.1;
            return [lo - pad, hi + pad];
          },
        },
      },
      axes: [
        { stroke: "#8fa3b8", grid: { stroke: "#2a3644" }, ticks: { stroke: "#2a3644" }, size: 28 },
        {
          stroke: "#8fa3b8",
          grid: { stroke: "#2a3644" },
          ticks: { stroke: "#2a3644" },
          // As wide as the widest label ("60000 pulse" needs more room than "1 mm").
          // Measured only when the labels change (every redraw asks).
          size: (u, values) => {
            if (!values || values.length === 0) return 40;
            const key = values.join("|");
            if (key === measured.key) return measured.size;
            const { ctx } = u;
            ctx.save();
            ctx.font = u.axes[1].font?.[0] || ctx.font;
            const widest = Math.max(...values.map((v) => ctx.measureText(v).width));
            ctx.restore();
            measured.key = key;
            measured.size = Math.ceil(widest / devicePixelRatio) + 14;
            return measured.size;
          },
          splits: (u, _i, min, max) => yTicks(u, min, max).values,
          // Every label carries the unit; the labels drawn are also on the element, for
          // screen readers and the tests.
          values: (u, splits) => {
            const unit = (store.axes.get(axisId) || {}).unit || "";
            const digits = splits.length > 1 ? tickDigits(Math.abs(splits[1] - splits[0])) : 0;
            const labels = splits.map((v) => `${v.toFixed(digits)} ${unit}`.trim());
            const joined = labels.join("|");
            if (el.dataset.yTicks !== joined) {
              el.dataset.yTicks = joined;
              el.setAttribute("aria-label", `position plot, scale ${labels[0] || ""} to ${labels[labels.length - 1] || ""}`);
            }
            return labels;
          },
        },
      ],
      series: [{}, { stroke: COLORS.position, width: 2, points: { show: false } }],
      hooks: {
        draw: [
          (u) => {
            const { axis, target } = marks();
            lines(u, [axis.soft_min, axis.soft_max], COLORS.limit, [6, 4]);
            lines(u, [target], COLORS.target, [2, 3]);
          },
        ],
      },
    };
    const plot = new uPlot(opts, [[], []], el);
    let lastLen = -1;
    let lastT = 0;
    let drawn = 0;
    let visible = true;
    const seen = new IntersectionObserver((entries) => {
      visible = entries[entries.length - 1].isIntersecting;
    });
    seen.observe(el);
    const redraw = () => {
      const at = performance.now();
      if (!visible || at - drawn < every) return;
      drawn = at;
      const h = store.history.get(axisId);
      if (!h || h.t.length === 0) return;
      const end = h.t[h.t.length - 1];
      const now = Date.now() / 1000;
      // Redraw when a point came or the window slid by a visible step.
      if (h.t.length === lastLen && end === lastT && now - lastT < 0.25) return;
      lastLen = h.t.length;
      lastT = end;
      let i = h.t.length - 1;
      while (i > 0 && h.t[i - 1] >= now - window) i -= 1;
      const t = h.t.slice(i);
      const v = h.v.slice(i);
      // Hold the last value to now: the line shows how long the axis has been there.
      t.push(Math.max(now, end));
      v.push(v[v.length - 1]);
      plot.batch(() => {
        plot.setData([t, v]);
        plot.setScale("x", { min: now - window, max: now });
      });
    };
    redraw();
    const unsubscribe = subscribe(redraw);
    const resize = new ResizeObserver(() => plot.setSize({ width: el.clientWidth || 300, height }));
    resize.observe(el);
    return () => {
      unsubscribe();
      resize.disconnect();
      seen.disconnect();
      plot.destroy();
    };
  }, [axisId, height, window, every]);
  return html`<div class="plot" ref=${box} role="img" aria-label="position plot" data-testid="plot"></div>`;
}
