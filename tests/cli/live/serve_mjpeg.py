#!/usr/bin/python3
"""Serves JPEG files as an MJPEG stream over HTTP on the loopback address, for the live tests.

usage: serve_mjpeg.py FPS SECONDS FRAME.jpg... [--parts N] [--garbage-at I] [--huge-at I]
                      [--huge-bytes B] [--stall-after N]

Prints the port it listens on (one line), then serves one client
`multipart/x-mixed-replace` parts, one JPEG each, at FPS frames a second, cycling through the
files, for SECONDS seconds (or N parts, whichever comes first); then it ends the stream, as a
camera that goes away would. A camera does not wait for its reader: frames are sent on time
whether or not the reader keeps up. Faults:
  --garbage-at I   part I (0-based) holds bytes that are no image
  --huge-at I      part I announces and sends --huge-bytes bytes (default 200 MB) of no image
  --stall-after N  after N parts, prints "stalling" and sends nothing more, keeping the
                   connection open until the client closes it (at most 60 s)
At the end it prints "sent N" (the parts sent).
"""
import argparse
import http.server
import select
import socketserver
import sys
import time


def main(argv):
    p = argparse.ArgumentParser()
    p.add_argument('fps', type=float)
    p.add_argument('seconds', type=float)
    p.add_argument('files', nargs='+')
    p.add_argument('--parts', type=int, default=None)
    p.add_argument('--garbage-at', type=int, default=None)
    p.add_argument('--huge-at', type=int, default=None)
    p.add_argument('--huge-bytes', type=int, default=200 * 1024 * 1024)
    p.add_argument('--stall-after', type=int, default=None)
    a = p.parse_args(argv[1:])
    frames = []
    for path in a.files:
        with open(path, 'rb') as f:
            frames.append(f.read())
    sent = [0]

    class Handler(http.server.BaseHTTPRequestHandler):
        def part(self, length, chunks):
            self.wfile.write(b'--frame\r\nContent-Type: image/jpeg\r\nContent-Length: '
                             + str(length).encode() + b'\r\n\r\n')
            for chunk in chunks:
                self.wfile.write(chunk)
            self.wfile.write(b'\r\n')
            self.wfile.flush()

        def huge(self):
            block = b'\x55' * (1 << 20)
            left = a.huge_bytes
            while left > 0:
                yield block[:min(left, len(block))]
                left -= len(block)

        def do_GET(self):
            self.send_response(200)
            self.send_header('Content-Type', 'multipart/x-mixed-replace; boundary=frame')
            self.end_headers()
            start = time.monotonic()
            i = 0
            try:
                while time.monotonic() - start < a.seconds and (a.parts is None or i < a.parts):
                    if a.stall_after is not None and i == a.stall_after:
                        print('stalling', flush=True)
                        select.select([self.connection], [], [], 60)
                        break
                    if i == a.garbage_at:
                        garbage = b'this part is no image\n' * 40
                        self.part(len(garbage), [garbage])
                    elif i == a.huge_at:
                        self.part(a.huge_bytes, self.huge())
                    else:
                        jpeg = frames[i % len(frames)]
                        self.part(len(jpeg), [jpeg])
                    i += 1
                    sent[0] = i
                    time.sleep(max(0.0, start + i / a.fps - time.monotonic()))
            except (BrokenPipeError, ConnectionResetError):
                pass

        def log_message(self, *args):
            pass

    with socketserver.TCPServer(('127.0.0.1', 0), Handler) as server:
        print(server.server_address[1], flush=True)
        server.handle_request()
    print(f'sent {sent[0]}', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
