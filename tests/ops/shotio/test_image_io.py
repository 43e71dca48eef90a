"""Image I/O's capture of C libraries' stderr must not swallow the lines meant for the user."""
from __future__ import annotations

import threading
import time

from ops.shotio.image_io import captured_stderr, say_on_stderr


def test_a_line_for_the_user_waits_for_another_threads_capture(capfd):
    inside, captured = threading.Event(), []

    def reader():  # a stage on a worker thread, reading an image while the run fails
        with captured_stderr() as noise:
            inside.set()
            time.sleep(0.3)
        captured.extend(noise)

    t = threading.Thread(target=reader)
    t.start()
    inside.wait()
    say_on_stderr("error: shot: stage: cause; fix: something")
    t.join()
    assert "error: shot" in capfd.readouterr().err
    assert "error: shot" not in "".join(captured)
