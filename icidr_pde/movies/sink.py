"""Where the frames of a movie go: the ffmpeg binary of the ``imageio-ffmpeg`` wheel on a pipe
(MP4; its ``write_frames``, no system package needed) or Pillow (GIF; also the fallback when no
ffmpeg can be found).

A movie is one figure drawn once: its axes, ticks and labels are kept as a background and each
frame draws only what moves on it (matplotlib's blitting), so a frame costs a few milliseconds,
not a full draw. A bar counts the frames written. A movie is written to a temporary name and
renamed when complete: a failure never leaves half a file. imageio-ffmpeg does not look at how
ffmpeg ended, and ffmpeg reports a full disk only when it writes the MP4's index at the end
("Error writing trailer"), so an MP4 counts as complete only when ffmpeg exited with status 0
and the file's top-level boxes hold the index (``moov``) and tile the whole file
(:func:`check_mp4`).
"""

from __future__ import annotations

import errno
import os
import struct
import warnings

import numpy as np

from ..ffmpeg import ffmpeg_exe
from ..outputs import replacing

__all__ = ["check_mp4", "ffmpeg_exe", "movie_target", "write_frames"]


#: imageio-ffmpeg's quality, 1-10 (6: H.264 crf 20, about the size of ffmpeg's default crf 23)
MP4_QUALITY = 6


def movie_target(path):
    """Check a movie's output `path`; return (path, suffix), a .gif beside it when an .mp4
    was asked for and no ffmpeg exists (with a warning to the public function's caller)."""
    if not path.parent.is_dir():
        raise ValueError(f"`path`: folder {path.parent} does not exist")
    suffix = path.suffix.lower()
    if suffix not in (".mp4", ".gif"):
        raise ValueError(f"`path` must end in .mp4 or .gif; got {path.name!r}")
    if suffix == ".mp4" and ffmpeg_exe() is None:
        warnings.warn("no ffmpeg found (install imageio-ffmpeg): writing a GIF instead", stacklevel=3)
        path, suffix = path.with_suffix(".gif"), ".gif"
    return path, suffix


class _FrameSink:
    """Where the RGBA frames of a movie go: ffmpeg on a pipe (.mp4) or Pillow (.gif)."""

    def __init__(self, path, suffix, size, fps):
        self.path, self.fps, self.images, self.pipe = path, fps, [], None
        if suffix == ".mp4":
            import imageio_ffmpeg

            # macro blocks of 2: the frame keeps its size (yuv420p needs it even)
            self.pipe = imageio_ffmpeg.write_frames(str(path), size, pix_fmt_in="rgba", fps=fps,
                                                    quality=MP4_QUALITY, macro_block_size=2,
                                                    output_params=["-preset", "veryfast"],  # 1/3 less CPU
                                                    ffmpeg_log_level="error")
            self.pipe.send(None)  # starts ffmpeg
            # the ffmpeg process of the generator, to read its exit status (imageio-ffmpeg keeps it
            # in its local `p`; None if a later version does not: the file's check still holds)
            frame = self.pipe.gi_frame
            self.ffmpeg = frame.f_locals.get("p") if frame is not None else None

    def send(self, rgba) -> None:
        """Take one frame: the canvas's RGBA buffer (written to ffmpeg as it is, without a copy)."""
        if self.pipe is not None:
            self.pipe.send(rgba)
        else:
            from PIL import Image

            self.images.append(Image.fromarray(np.asarray(rgba)[..., :3]))

    def close(self) -> None:
        """Finish the file (ffmpeg: end of input, wait for it)."""
        if self.pipe is not None:
            self.pipe.close()
            status = getattr(self.ffmpeg, "returncode", None)
            if status:
                raise _unfinished(self.path, f"ffmpeg ended with exit status {status}")
            check_mp4(self.path)
        elif self.images:
            self.images[0].save(self.path, save_all=True, append_images=self.images[1:],
                                duration=int(round(1000 / self.fps)), loop=0)


def _unfinished(path, why: str) -> OSError:
    """The OSError of an MP4 ffmpeg did not finish: ENOSPC when its folder has no space left (the
    usual cause, and ffmpeg's message above says so), else EIO."""
    try:
        full = os.statvfs(os.path.dirname(os.path.abspath(path))).f_bavail == 0
    except OSError:
        full = False
    if full:
        return OSError(errno.ENOSPC, f"No space left on device ({why})", str(path))
    return OSError(errno.EIO, f"the movie was not finished ({why})", str(path))


def check_mp4(path) -> None:
    """OSError unless the top-level boxes of the MP4 file `path` tile it from its first byte to
    its last and include ``ftyp``, ``mdat`` and the index ``moov`` (written last by ffmpeg)."""
    seen = set()
    with open(path, "rb") as f:
        end = os.fstat(f.fileno()).st_size
        at = 0
        while at < end:
            f.seek(at)
            header = f.read(16)
            if len(header) < 8:
                break
            size, kind = struct.unpack(">I4s", header[:8])
            if size == 1 and len(header) == 16:  # a 64-bit size follows the type
                size = struct.unpack(">Q", header[8:])[0]
            elif size == 0:  # the box runs to the end of the file
                size = end - at
            if size < 8:
                break
            seen.add(kind)
            at += size
    if at != end or not {b"ftyp", b"mdat", b"moov"} <= seen:
        missing = sorted(k.decode() for k in {b"ftyp", b"mdat", b"moov"} - seen)
        raise _unfinished(path, f"{'no ' + ', '.join(missing) if missing else 'a box runs past its end'}")


def write_frames(fig, path, suffix, fps, add_frames, *, animated=(), n_frames=None, progress=False):
    """Write the frames `add_frames(grab)` draws on `fig` to a temporary name beside `path`,
    installed at `path` when complete (never a half-written file; :mod:`icidr_pde.outputs`)
    and return `path`.

    `grab(fig, redraw=False)` takes a frame. The figure is drawn in full once, without its
    `animated` artists, and kept as background; a frame restores it and draws only those
    (blitting). `redraw=True`, or no `animated` artists, draws the whole figure anew.
    `progress`: a bar over the `n_frames` frames.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from tqdm.auto import tqdm

    canvas = FigureCanvasAgg(fig)
    for artist in animated:
        artist.set_animated(True)
    background = None

    def grab(_fig=None, redraw=False):
        nonlocal background
        if background is None or redraw or not animated:
            canvas.draw()
            background = canvas.copy_from_bbox(fig.bbox)
        else:
            canvas.restore_region(background)
        for artist in animated:
            fig.draw_artist(artist)
        sink.send(canvas.buffer_rgba())
        bar.update(1)  # after the frame is handed to the encoder: the bar counts frames written

    with replacing(path, suffix) as partial, \
            tqdm(total=n_frames, desc=f"{path.name}: frames", unit="frame", disable=not progress,
                 leave=True) as bar:
        sink = _FrameSink(partial, suffix, canvas.get_width_height(), fps)
        try:
            add_frames(grab)
        finally:
            sink.close()
    return path
