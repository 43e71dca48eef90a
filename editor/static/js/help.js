// The keyboard shortcuts: one table, read both by the key handler (main.js) and by the help panel.

export const SHORTCUTS = [
  { keys: ['v'], label: 'V', action: 'tool-select', what: 'Move tool: drag joints and T-junctions; drag empty space to pan' },
  { keys: ['t'], label: 'T', action: 'tool-tjunction', what: 'T-junction tool: click to add, drag to move' },
  { keys: ['b'], label: 'B', action: 'tool-paint', what: 'Paint the active mask layer' },
  { keys: ['e'], label: 'E', action: 'tool-erase', what: 'Erase from the active mask layer' },
  { keys: ['j'], label: 'J', action: 'tool-skeleton',
    what: 'Skeleton tool: click paper to add a joint (child of the selected one); drag from a joint onto another to make it its parent, or onto paper for a new child' },
  { keys: ['g'], label: 'G', action: 'tool-template', what: 'Template tool: drag a box around the character to place the chosen skeleton template' },
  { keys: ['['], label: '[  ]', action: 'brush-smaller', what: 'Brush smaller / larger' },
  { keys: [']'], label: null, action: 'brush-larger' },
  { keys: [','], label: ',  .', action: 'key-prev', what: 'Select the previous / next key of the timeline' },
  { keys: ['.'], label: null, action: 'key-next' },
  { keys: ['n'], label: 'N', action: 'new-region', what: 'New occlusion region on the focused keyframe' },
  { keys: ['Delete', 'Backspace'], label: 'Delete', action: 'delete', what: 'Delete the selected T-junction or joint (its children go to its parent)' },
  { keys: ['ArrowLeft', 'ArrowRight', 'ArrowUp', 'ArrowDown'], label: 'Arrows', action: 'nudge',
    what: 'Nudge the selected joint or T-junction by 1 px (Shift: 0.1 px); in Results: previous / next frame' },
  { keys: ['ctrl+z'], label: 'Ctrl+Z', action: 'undo', what: 'Undo' },
  { keys: ['ctrl+shift+z', 'ctrl+y'], label: 'Ctrl+Shift+Z', action: 'redo', what: 'Redo' },
  { keys: ['ctrl+s'], label: 'Ctrl+S', action: 'save', what: 'Save: validate, write, rerun in the background' },
  { keys: ['f', '0'], label: 'F', action: 'fit', what: 'Fit the keyframes in their panes (or double-click)' },
  { keys: ['1'], label: '1  2  3', action: 'view-annotate', what: 'Annotate / Pose / Results view' },
  { keys: ['2'], label: null, action: 'view-pose' },
  { keys: ['3'], label: null, action: 'view-results' },
  { keys: ['p'], label: 'P', action: 'play', what: 'Results: play / pause' },
  { keys: ['o'], label: 'O', action: 'onion', what: 'Results: onion skin of the neighbouring frames' },
  { keys: ['a'], label: 'A', action: 'add-pose', what: 'Pose: add the dragged pose to the motion at t' },
  { keys: ['?', 'h'], label: '?', action: 'help', what: 'This help' },
  { keys: ['Escape'], label: 'Esc', action: 'escape', what: 'Close help, clear the selection and the error' },
];

export const MOUSE = [
  ['Wheel', 'Zoom about the pointer'],
  ['Wheel over a joint', 'Depth z of the joint (Shift: 10x); up = nearer'],
  ['Space + drag, middle or right drag', 'Pan'],
  ['Alt + click a T-junction', 'Delete it'],
  ['Click a proposal (hollow teal diamond)', 'Accept it as a T-junction'],
];

/** The action bound to a keydown event, or null. */
export function actionFor(e) {
  const mod = (e.ctrlKey || e.metaKey ? 'ctrl+' : '') + (e.shiftKey && (e.ctrlKey || e.metaKey) ? 'shift+' : '');
  const key = e.key.length === 1 ? e.key.toLowerCase() : e.key;
  const hit = SHORTCUTS.find((s) => s.keys.includes(mod + key) || (!mod && s.keys.includes(e.key)));
  return hit ? hit.action : null;
}

export function renderHelp(table) {
  const row = (k, what) => {
    const tr = document.createElement('tr');
    const a = document.createElement('td');
    k.split('  ').forEach((part) => { const kbd = document.createElement('kbd'); kbd.textContent = part; a.append(kbd, ' '); });
    const b = document.createElement('td');
    b.textContent = what;
    tr.append(a, b);
    table.append(tr);
  };
  for (const s of SHORTCUTS) if (s.label) row(s.label, s.what);
  for (const [k, what] of MOUSE) row(k, what);
}
