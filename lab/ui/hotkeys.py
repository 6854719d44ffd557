"""Hotkeys that work after any widget has been used.

Viser's hotkeys (Mantine's `useHotkeys`) ignore a key pressed while an INPUT has the focus, and
a widget keeps the focus after it is used: a dropdown (viser's are searchable: X went into its
search box, and the robot did not stop), a checkbox, a slider's number box. The page therefore
gets a small script that hands a hotkey pressed in such a widget to the hotkeys: it takes the
focus off the widget and sends the key on from the page's body. A key typed into a text box
(the gains), or into an open dropdown's search, stays there.

Viser has no way to run a script in the page; an HTML element's `onerror` handler runs when
the element is inserted (an image of an empty data URL fails at once), so the script is that.
"""

import viser

# JavaScript, single-quoted strings only (it sits in a double-quoted HTML attribute); KEYS is
# replaced by the hotkeys' letters. Installed once per page, whatever the number of panels.
_SCRIPT = """
if (!window.__labHotkeys) {
  window.__labHotkeys = true;
  const keys = new Set(KEYS);
  window.addEventListener('keydown', (e) => {
    const t = e.target;
    if (!(t instanceof HTMLInputElement) || !e.isTrusted) return;
    if (e.ctrlKey || e.metaKey || e.altKey || !keys.has(e.key.toLowerCase())) return;
    const searching = t.getAttribute('aria-expanded') === 'true';
    const numeric = ['numeric', 'decimal'].includes(t.inputMode);
    const choice = t.hasAttribute('aria-expanded')
      || ['checkbox', 'radio', 'range'].includes(t.type);
    if (searching || !(choice || numeric)) return;
    e.preventDefault();
    e.stopPropagation();
    t.blur();
    const again = {key: e.key, code: e.code, bubbles: true};
    document.body.dispatchEvent(new KeyboardEvent('keydown', again));
  }, true);
}
"""


def hotkey_script_html(keys: str) -> str:
    """The hidden element whose handler installs the script for hotkeys `keys` (letters)."""
    letters = "[" + ", ".join(f"'{k.lower()}'" for k in keys) + "]"
    script = " ".join(line.strip() for line in _SCRIPT.replace("KEYS", letters).splitlines())
    return f'<img src="data:," alt="" style="display:none" onerror="{script}">'


def install_hotkey_script(gui: viser.GuiApi, keys: str) -> viser.GuiHtmlHandle:
    """Add the script (lab/ui/hotkeys.py's docstring) to every page of `gui`."""
    return gui.add_html(hotkey_script_html(keys))
