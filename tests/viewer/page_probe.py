#!/usr/bin/env python3
"""Loads a page in headless Chromium and waits, in real time, until its title is the expected one.

Chromium is driven through the DevTools protocol over a pipe (--remote-debugging-pipe: JSON messages ended
by a NUL byte, commands on fd 3, replies and events on fd 4), so no WebSocket library is needed. Unlike
--dump-dom with --virtual-time-budget, the wait is real time: a page fed over a WebSocket by a busy server
is given the time the data needs.

Usage: page_probe.py URL --title EXPECTED [--timeout S] [--dom OUT.html] [--screenshot OUT.png]
                     [--size W,H] [--chromium-log FILE]
Prints the last title seen. Exit 0 when the title was reached, 1 when not (the DOM and screenshot are
written either way, for the caller's checks and diagnosis), 2 when Chromium failed.
"""
import argparse
import base64
import json
import os
import select
import subprocess
import sys
import tempfile
import time


class DevTools:
    def __init__(self, args, log):
        to_chrome_r, self.to_chrome = os.pipe()
        self.from_chrome, from_chrome_w = os.pipe()
        # The child's fd 3 reads commands, its fd 4 writes replies. os.pipe()'s descriptors are not inherited
        # (close-on-exec); dup2's copies are, and only those two.
        def child_fds():
            os.dup2(to_chrome_r, 3)
            os.dup2(from_chrome_w, 4)
        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                                     preexec_fn=child_fds, close_fds=False)
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self.buffer = b""
        self.next_id = 0

    def call(self, method, params=None, session=None, timeout=30.0):
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self.to_chrome, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            while b"\0" in self.buffer:
                raw, self.buffer = self.buffer.split(b"\0", 1)
                reply = json.loads(raw)
                if reply.get("id") == self.next_id:
                    if "error" in reply:
                        raise RuntimeError(f"{method}: {reply['error']}")
                    return reply.get("result", {})
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"{method}: no reply within {timeout:.0f} s")
            ready, _, _ = select.select([self.from_chrome], [], [], left)
            if ready:
                chunk = os.read(self.from_chrome, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"{method}: Chromium closed the pipe (exit {self.proc.poll()})")
                self.buffer += chunk

    def close(self):
        try:
            self.call("Browser.close", timeout=5)
        except (RuntimeError, TimeoutError, OSError):
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("url")
    parser.add_argument("--title", required=True)
    parser.add_argument("--timeout", type=float, default=90.0)
    parser.add_argument("--dom")
    parser.add_argument("--screenshot")
    parser.add_argument("--size", default="1280,800")
    parser.add_argument("--chromium-log", default=os.devnull)
    opts = parser.parse_args()
    width, height = (int(v) for v in opts.size.split(","))
    profile = tempfile.mkdtemp(prefix="page_probe.")
    args = ["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--enable-unsafe-swiftshader", f"--user-data-dir={profile}", f"--window-size={width},{height}",
            "--remote-debugging-pipe", "about:blank"]
    with open(opts.chromium_log, "ab") as log:
        devtools = DevTools(args, log)
        try:
            target = devtools.call("Target.createTarget", {"url": "about:blank"})
            session = devtools.call("Target.attachToTarget",
                                    {"targetId": target["targetId"], "flatten": True})["sessionId"]
            devtools.call("Emulation.setDeviceMetricsOverride",
                          {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False}, session)
            devtools.call("Page.navigate", {"url": opts.url}, session)
            deadline = time.monotonic() + opts.timeout
            title = ""
            while True:
                title = devtools.call("Runtime.evaluate", {"expression": "document.title", "returnByValue": True},
                                      session)["result"].get("value", "")
                if title == opts.title or time.monotonic() > deadline:
                    break
                time.sleep(0.25)
            reached = title == opts.title
            if reached:
                time.sleep(0.5)  # a few more animation frames: the frame with the title is on screen
            if opts.dom:
                dom = devtools.call("Runtime.evaluate",
                                    {"expression": "document.documentElement.outerHTML", "returnByValue": True},
                                    session)["result"].get("value", "")
                with open(opts.dom, "w", encoding="utf-8") as f:
                    f.write(dom)
            if opts.screenshot:
                shot = devtools.call("Page.captureScreenshot", {"format": "png"}, session, timeout=120)
                with open(opts.screenshot, "wb") as f:
                    f.write(base64.b64decode(shot["data"]))
        except (RuntimeError, TimeoutError, OSError, KeyError, ValueError) as e:
            print(f"chromium: {e}", file=sys.stderr)
            return 2
        finally:
            devtools.close()
            subprocess.run(["rm", "-rf", profile], check=False)
    print(title)
    return 0 if reached else 1


if __name__ == "__main__":
    sys.exit(main())
