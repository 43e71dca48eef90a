// Mask layers: one canvas per mask at keyframe size, white and opaque inside, transparent outside.

import { loadImage } from './api.js';

// ops/preview.py's palette (tab10 without red and grey): region i has the same colour as in the stage previews
export const PALETTE = ['#1f77b4', '#ff7f0e', '#2ca02c', '#9467bd', '#17becf', '#bcbd22', '#e377c2', '#8c564b'];
export const FOREGROUND_COLOUR = '#78c878';
export const regionColour = (i) => PALETTE[i % PALETTE.length];

let nextId = 1;

export class MaskLayer {
  /** name: the file the saved shot.json names (null until first saved). */
  constructor(width, height, name = null) {
    this.id = nextId++;
    this.name = name;
    this.dirty = false;
    this.canvas = document.createElement('canvas');
    this.canvas.width = width;
    this.canvas.height = height;
    this.ctx = this.canvas.getContext('2d', { willReadFrequently: true });
    this._tint = null;
  }

  /** Fill from a grey mask image (255 = inside), as the server sends them. */
  setFromGrey(img) {
    const { width: w, height: h } = this.canvas;
    const c = document.createElement('canvas');
    c.width = w; c.height = h;
    const cx = c.getContext('2d', { willReadFrequently: true });
    cx.drawImage(img, 0, 0, w, h);
    const src = cx.getImageData(0, 0, w, h);
    const out = this.ctx.createImageData(w, h);
    for (let i = 0; i < src.data.length; i += 4) {
      const v = src.data[i] >= 128 ? 255 : 0;
      out.data[i] = out.data[i + 1] = out.data[i + 2] = out.data[i + 3] = v;
    }
    this.ctx.putImageData(out, 0, 0);
    this.changed();
  }

  copyFrom(other) {
    this.ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    this.ctx.drawImage(other.canvas, 0, 0);
    this.changed();
  }

  changed() { this._tint = null; }

  /** The mask in one colour, for drawing over the keyframe. */
  tinted(colour) {
    if (!this._tint || this._tint.colour !== colour) {
      const c = document.createElement('canvas');
      c.width = this.canvas.width; c.height = this.canvas.height;
      const cx = c.getContext('2d');
      cx.drawImage(this.canvas, 0, 0);
      cx.globalCompositeOperation = 'source-in';
      cx.fillStyle = colour;
      cx.fillRect(0, 0, c.width, c.height);
      this._tint = { colour, canvas: c };
    }
    return this._tint.canvas;
  }

  /** Paint (or erase) a round-capped segment in image pixels; returns its bounding box [x, y, w, h]. */
  stroke(x0, y0, x1, y1, radius, erase) {
    const cx = this.ctx;
    cx.save();
    cx.globalCompositeOperation = erase ? 'destination-out' : 'source-over';
    cx.strokeStyle = cx.fillStyle = '#fff';
    cx.lineCap = 'round';
    cx.lineWidth = 2 * radius;
    // +0.5: image coordinates put pixel centres at integers, the canvas at half-integers
    cx.beginPath();
    cx.moveTo(x0 + 0.5, y0 + 0.5);
    cx.lineTo(x1 + 0.5 + 1e-3, y1 + 0.5);
    cx.stroke();
    cx.restore();
    this.changed();
    const r = radius + 2;
    return [Math.floor(Math.min(x0, x1) - r), Math.floor(Math.min(y0, y1) - r),
      Math.ceil(Math.abs(x1 - x0) + 2 * r + 1), Math.ceil(Math.abs(y1 - y0) + 2 * r + 1)];
  }

  pixelCount() {
    const d = this.ctx.getImageData(0, 0, this.canvas.width, this.canvas.height).data;
    let n = 0;
    for (let i = 3; i < d.length; i += 4) n += d[i] >= 128;
    return n;
  }

  toBlob() {
    return new Promise((resolve) => this.canvas.toBlob(resolve, 'image/png'));
  }
}

/** A layer filled from a mask PNG at url. */
export async function layerFromUrl(url, width, height, name = null) {
  const layer = new MaskLayer(width, height, name);
  layer.setFromGrey(await loadImage(url));
  return layer;
}
