package orb.model

import java.io.File
import javax.imageio.ImageIO
import java.awt.image.BufferedImage

/** An 8-bit grayscale image, row-major. */
final case class GrayImage(width: Int, height: Int, pixels: Array[Int]) {
  require(width > 0 && height > 0 && pixels.length == width * height, s"bad image buffer for ${width}x$height")
  def apply(x: Int, y: Int): Int = pixels(y * width + x)
  def crop(x0: Int, y0: Int, w: Int, h: Int): GrayImage = {
    require(
      x0 >= 0 && y0 >= 0 && x0 + w <= width && y0 + h <= height,
      s"crop $w x $h at ($x0,$y0) outside ${width}x$height"
    )
    GrayImage(w, h, Array.tabulate(w * h)(i => this(x0 + i % w, y0 + i / w)))
  }
  def toBufferedImage: BufferedImage = {
    val img = new BufferedImage(width, height, BufferedImage.TYPE_BYTE_GRAY)
    img.getRaster.setPixels(0, 0, width, height, pixels)
    img
  }
  def save(file: File): Unit = {
    file.getAbsoluteFile.getParentFile.mkdirs(); ImageIO.write(toBufferedImage, "png", file)
  }
}

object GrayImage {
  def tabulate(width: Int, height: Int)(f: (Int, Int) => Int): GrayImage =
    GrayImage(width, height, Array.tabulate(width * height)(i => f(i % width, i / width) max 0 min 255))

  /** Reads a PNG/JPEG/...; colour images are converted with the usual luma weights, rounded. */
  def load(file: File): GrayImage = {
    if (!file.isFile) throw new IllegalArgumentException(s"no such image file: $file")
    val img =
      try ImageIO.read(file)
      catch { case e: java.io.IOException => null }
    if (img == null) throw new IllegalArgumentException(s"not a readable image: $file")
    val w = img.getWidth; val h = img.getHeight
    if (img.getType == BufferedImage.TYPE_BYTE_GRAY) {
      GrayImage(w, h, img.getRaster.getPixels(0, 0, w, h, null: Array[Int]))
    } else {
      val rgb = img.getRGB(0, 0, w, h, null, 0, w)
      GrayImage(
        w,
        h,
        rgb.map { p =>
          val r = (p >> 16) & 0xff; val g = (p >> 8) & 0xff; val b = p & 0xff
          math.round(0.299 * r + 0.587 * g + 0.114 * b).toInt
        }
      )
    }
  }
  def load(path: String): GrayImage = load(new File(path))
}
