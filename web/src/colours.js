// Object k's colour (RGB 0..255) in the viewer and in report.html.
export const COLOURS = [[255, 80, 60], [60, 200, 255], [120, 230, 90], [250, 200, 50], [200, 110, 255], [255, 140, 200]];
export const colourOf = (k) => COLOURS[k % COLOURS.length];
