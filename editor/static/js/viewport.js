// Zoom and pan of a canvas showing an image: screen = image * zoom + pan (CSS pixels), image pixels with
// their centres at integer coordinates (docs/shot-format.md), so pixel i covers [i - 0.5, i + 0.5).

export class Viewport {
  constructor() { this.zoom = 1; this.panX = 0; this.panY = 0; }

  /** Fit an image of w x h into a cw x ch box with a margin. */
  fit(w, h, cw, ch, margin = 0.94) {
    this.zoom = Math.max(0.05, Math.min(cw / w, ch / h) * margin);
    this.panX = (cw - w * this.zoom) / 2 + 0.5 * this.zoom;
    this.panY = (ch - h * this.zoom) / 2 + 0.5 * this.zoom;
  }

  toScreen(x, y) { return [x * this.zoom + this.panX, y * this.zoom + this.panY]; }
  toImage(sx, sy) { return [(sx - this.panX) / this.zoom, (sy - this.panY) / this.zoom]; }

  /** Zoom by factor about a screen point, which stays put. */
  zoomAt(factor, sx, sy) {
    const z = Math.min(64, Math.max(0.05, this.zoom * factor));
    const [x, y] = this.toImage(sx, sy);
    this.zoom = z;
    this.panX = sx - x * z;
    this.panY = sy - y * z;
  }

  /** Apply to a 2D context whose canvas has `dpr` device pixels per CSS pixel. */
  apply(ctx, dpr) { ctx.setTransform(this.zoom * dpr, 0, 0, this.zoom * dpr, this.panX * dpr, this.panY * dpr); }
}

/** Size a canvas's backing store to its CSS box; returns [cssWidth, cssHeight, dpr]. */
export function fitCanvas(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const { width, height } = canvas.getBoundingClientRect();
  const w = Math.max(1, Math.round(width * dpr)), h = Math.max(1, Math.round(height * dpr));
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  return [width, height, dpr];
}
