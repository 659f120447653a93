//! Frames to a file: GIF through the `gif` crate (palette per frame), MP4 (H.264) through Debian's ffmpeg.
//! Written to a temporary file and moved into place when finished, so an interrupted run leaves nothing half
//! written under the requested name.

use crate::error::{ensure, invalid, Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

enum Sink {
    Gif(gif::Encoder<std::fs::File>),
    Ffmpeg(Child, ChildStdin),
}

pub struct VideoWriter {
    sink: Option<Sink>,
    tmp: PathBuf,
    path: PathBuf,
    width: usize,
    height: usize,
    fps: u32,
    frames: usize,
}

impl VideoWriter {
    /// A writer for `path` (.gif or .mp4) of `width` × `height` RGB frames at `fps`.
    pub fn create(path: &Path, width: usize, height: usize, fps: u32) -> Result<VideoWriter> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        let tmp = path.with_extension(format!("{ext}.tmp"));
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(Error::io("creating", dir))?;
        }
        let sink = match ext.as_str() {
            "gif" => {
                let f = std::fs::File::create(&tmp).map_err(Error::io("creating", &tmp))?;
                let mut e = gif::Encoder::new(f, width as u16, height as u16, &[])?;
                e.set_repeat(gif::Repeat::Infinite)?;
                Sink::Gif(e)
            }
            "mp4" => {
                let mut child = Command::new("ffmpeg")
                    .args(["-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s"])
                    .arg(format!("{width}x{height}"))
                    .args(["-r", &fps.to_string(), "-i", "-", "-c:v", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4"])
                    .arg(&tmp)
                    .stdin(Stdio::piped())
                    .spawn()
                    .map_err(|source| Error::Ffmpeg {
                        message: "cannot run ffmpeg for MP4: `apt-get install -y ffmpeg`, or write a .gif instead",
                        source,
                    })?;
                let stdin = child.stdin.take().ok_or_else(|| Error::Video("ffmpeg has no stdin".into()))?;
                Sink::Ffmpeg(child, stdin)
            }
            _ => invalid!("{}: the video format is chosen by the extension, .gif or .mp4", path.display()),
        };
        Ok(VideoWriter { sink: Some(sink), tmp, path: path.to_path_buf(), width, height, fps, frames: 0 })
    }

    pub fn write(&mut self, rgb: &[u8]) -> Result<()> {
        ensure!(rgb.len() == 3 * self.width * self.height, "frame size does not match the video");
        match self.sink.as_mut().ok_or_else(|| Error::Video("video already finished".into()))? {
            Sink::Gif(e) => {
                let mut f = gif::Frame::from_rgb_speed(self.width as u16, self.height as u16, rgb, 10);
                f.delay = (100.0 / self.fps as f64).round() as u16; // hundredths of a second
                e.write_frame(&f)?;
            }
            Sink::Ffmpeg(_, stdin) => stdin
                .write_all(rgb)
                .map_err(|source| Error::Ffmpeg { message: "ffmpeg stopped reading frames", source })?,
        }
        self.frames += 1;
        Ok(())
    }

    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Completes the file and moves it into place.
    pub fn finish(mut self) -> Result<PathBuf> {
        match self.sink.take().ok_or_else(|| Error::Video("video already finished".into()))? {
            Sink::Gif(e) => drop(e.into_inner()?),
            Sink::Ffmpeg(mut child, stdin) => {
                drop(stdin);
                let status = child.wait().map_err(|source| Error::Ffmpeg { message: "waiting for ffmpeg", source })?;
                if !status.success() {
                    return Err(Error::Video(format!("ffmpeg failed ({status})")));
                }
            }
        }
        std::fs::rename(&self.tmp, &self.path).map_err(Error::io("moving the video to", &self.path))?;
        Ok(self.path.clone())
    }
}

impl Drop for VideoWriter {
    fn drop(&mut self) {
        if self.sink.is_some() {
            // Not finished (an error on the way): leave no partial file behind.
            if let Some(Sink::Ffmpeg(mut child, _)) = self.sink.take() {
                let _ = child.kill();
                let _ = child.wait();
            }
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}
