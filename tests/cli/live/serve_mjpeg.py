#!/usr/bin/python3
"""Serves JPEG files as an MJPEG stream over HTTP on the loopback address, for the live tests.

usage: serve_mjpeg.py FPS SECONDS FRAME.jpg...

Prints the port it listens on (one line), then serves one client
`multipart/x-mixed-replace` parts, one JPEG each, at FPS frames a second, cycling through the
files, for SECONDS seconds; then it ends the stream, as a camera that goes away would. A camera
does not wait for its reader: frames are sent on time whether or not the reader keeps up.
"""
import http.server
import socketserver
import sys
import time


def main(argv):
    fps, seconds, files = float(argv[1]), float(argv[2]), argv[3:]
    frames = []
    for path in files:
        with open(path, 'rb') as f:
            frames.append(f.read())

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            self.send_response(200)
            self.send_header('Content-Type', 'multipart/x-mixed-replace; boundary=frame')
            self.end_headers()
            start = time.monotonic()
            i = 0
            try:
                while time.monotonic() - start < seconds:
                    jpeg = frames[i % len(frames)]
                    self.wfile.write(b'--frame\r\nContent-Type: image/jpeg\r\nContent-Length: '
                                     + str(len(jpeg)).encode() + b'\r\n\r\n' + jpeg + b'\r\n')
                    self.wfile.flush()
                    i += 1
                    time.sleep(max(0.0, start + i / fps - time.monotonic()))
            except (BrokenPipeError, ConnectionResetError):
                pass

        def log_message(self, *args):
            pass

    with socketserver.TCPServer(('127.0.0.1', 0), Handler) as server:
        print(server.server_address[1], flush=True)
        server.handle_request()
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
