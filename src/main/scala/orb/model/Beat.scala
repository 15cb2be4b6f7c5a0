package orb.model

/** One valid clock of the camera stream: a pixel with its frame/line markers (see `orb.PixelBeat`). */
final case class Beat(luma: Int, sof: Boolean, eol: Boolean, keyframe: Boolean = false)

object Beat {

  /** A well-formed frame: sof on its first pixel, eol on the last pixel of every line. */
  def frame(img: GrayImage, keyframe: Boolean = false): Seq[Beat] =
    for (y <- 0 until img.height; x <- 0 until img.width)
      yield Beat(img(x, y), sof = x == 0 && y == 0, eol = x == img.width - 1, keyframe = keyframe && x == 0 && y == 0)
}
