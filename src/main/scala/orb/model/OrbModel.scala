package orb.model

import orb.{OrbDescriptorConfig, Pattern}
import orb.OrbDescriptorConfig._

/** A feature as the core emits it: a Harris corner with its orientation bin and 256-bit descriptor, stored as
  * OpenCV stores it (byte i/8, bit i%8 least significant first). */
final case class Feature(x: Int, y: Int, bin: Int, score: Long, descriptor: Vector[Int]) {
  require(descriptor.size == OrbDescriptorConfig.descriptorBytes)

  /** the descriptor as one number: byte i in bits 8i .. 8i + 7, so bit i is test i */
  def descriptorBits: BigInt = descriptor.zipWithIndex.map { case (b, i) => BigInt(b) << (8 * i) }.sum
  def hex: String = descriptor.map(b => f"$b%02x").mkString
  def bit(i: Int): Int = (descriptor(i / 8) >> (i % 8)) & 1
}

object Feature {

  /** the descriptor bytes of a `descriptorBits` number */
  def descriptorOf(bits: BigInt): Vector[Int] =
    Vector.tabulate(OrbDescriptorConfig.descriptorBytes)(b => ((bits >> (8 * b)) & 0xff).toInt)
}

/** Integer model of the ORB descriptor stage, one function per step. Everything a hardware stage computes is
  * defined here in integers: the blur kernel, the moments, the angle search against fixed-point tangents and the
  * pattern rotation with fixed-point cos/sin. */
object OrbModel {

  /** 7x7 Gaussian, sigma 2, exactly as OpenCV's 8-bit fixed-point path: horizontal then vertical pass with the
    * integer kernel (sum 256 each), one rounding at the end: (sum + 2^15) >> 16. Pixels within 3 of an edge are 0. */
  def smooth(img: GrayImage): GrayImage = {
    val (w, h) = (img.width, img.height)
    val r = blurRadius
    val hor = Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      if (x < r || x >= w - r) 0L else blurKernel.indices.map(j => blurKernel(j).toLong * img(x + j - r, y)).sum
    }
    GrayImage(
      w,
      h,
      Array.tabulate(w * h) { i =>
        val (x, y) = (i % w, i / w)
        if (y < r || y >= h - r || x < r || x >= w - r) 0
        else ((blurKernel.indices.map(j => blurKernel(j) * hor((y + j - r) * w + x)).sum + (1L << 15)) >> 16).toInt
      }
    )
  }

  /** Offsets (u, v) of OpenCV's circular orientation patch (radius 15, half widths `umax`). */
  lazy val disc: IndexedSeq[(Int, Int)] =
    for (v <- -patchRadius to patchRadius; u <- -umax(v.abs) to umax(v.abs)) yield (u, v)

  /** Intensity moments on the raw image, as OpenCV's IC_Angle: m10 = sum u I, m01 = sum v I. */
  def moments(img: GrayImage, x: Int, y: Int): (Long, Long) = {
    var m10, m01 = 0L
    for ((u, v) <- disc) { val p = img(x + u, y + v); m10 += u * p; m01 += v * p }
    (m10, m01)
  }

  /** tan of the bin boundaries inside the first octant, (j + 1/2) bins for j < binsPerOctant, scaled 2^tanFracBits. */
  def boundaryTangents(cfg: OrbDescriptorConfig): IndexedSeq[Long] = cfg.boundaryTangents

  /** The orientation bin nearest to atan2(m01, m10), without a division: fold into the first octant by signs and
    * a swap, count the boundaries below the angle (b 2^F >= a T_j), unfold. (0, 0) is bin 0, as OpenCV's angle 0. */
  def angleBin(m10: Long, m01: Long, cfg: OrbDescriptorConfig): Int = {
    val n = cfg.angleBins; val quarter = n / 4
    val (ax, ay) = (m10.abs, m01.abs)
    val swap = ay > ax
    val (a, b) = if (swap) (ay, ax) else (ax, ay)
    val j = if (a == 0) 0 else boundaryTangents(cfg).count(t => BigInt(b) * (1L << cfg.tanFracBits) >= BigInt(a) * t)
    val inQuadrant = if (swap) 2 * cfg.binsPerOctant - j else j // 0..quarter
    val bin = (m10 >= 0, m01 >= 0) match {
      case (true, true) => inQuadrant
      case (false, true) => 2 * quarter - inQuadrant
      case (false, false) => 2 * quarter + inQuadrant
      case (true, false) => n - inQuadrant
    }
    bin % n
  }

  def binDegrees(bin: Int, cfg: OrbDescriptorConfig): Double = bin * cfg.binDegrees

  /** cos and sin of a bin's angle, scaled 2^rotationFracBits. */
  def cosSin(bin: Int, cfg: OrbDescriptorConfig): (Long, Long) = cfg.cosSin(bin)

  /** v / 2^f rounded half to even, as OpenCV's cvRound. */
  def roundHalfEven(v: Long, f: Int): Int = {
    val q = Math.floorDiv(v, 1L << f); val r = v - (q << f); val half = 1L << (f - 1)
    (if (r > half || (r == half && (q & 1) == 1)) q + 1 else q).toInt
  }

  /** A pattern point rotated by the bin's angle: x' = x cos - y sin, y' = x sin + y cos, each rounded. */
  def rotate(x: Int, y: Int, cs: (Long, Long), cfg: OrbDescriptorConfig): (Int, Int) = {
    val (c, s) = cs; val f = cfg.rotationFracBits
    (roundHalfEven(x * c - y * s, f), roundHalfEven(x * s + y * c, f))
  }

  private val rotatedCache =
    scala.collection.concurrent.TrieMap[(OrbDescriptorConfig, Int), IndexedSeq[(Int, Int, Int, Int)]]()

  /** The 256 tests of a bin, rotated. */
  def rotatedTests(bin: Int, cfg: OrbDescriptorConfig): IndexedSeq[(Int, Int, Int, Int)] =
    rotatedCache.getOrElseUpdate(
      (cfg, bin), {
        val cs = cosSin(bin, cfg)
        Pattern.tests.map { t =>
          val (x1, y1) = rotate(t.x1, t.y1, cs, cfg); val (x2, y2) = rotate(t.x2, t.y2, cs, cfg)
          (x1, y1, x2, y2)
        }
      }
    )

  /** Bit i = smoothed(p1) < smoothed(p2), packed as OpenCV does. */
  def descriptor(smoothed: GrayImage, x: Int, y: Int, bin: Int, cfg: OrbDescriptorConfig): Vector[Int] = {
    val tests = rotatedTests(bin, cfg)
    Vector.tabulate(32) { byte =>
      (0 until 8).map { bit =>
        val (x1, y1, x2, y2) = tests(byte * 8 + bit)
        if (smoothed(x + x1, y + y1) < smoothed(x + x2, y + y2)) 1 << bit else 0
      }.sum
    }
  }

  /** Features of the given corners (which keep at least `sampleReach + blurRadius` from every edge). */
  def features(img: GrayImage, corners: Seq[Corner], cfg: OrbDescriptorConfig): Seq[Feature] = {
    val smoothed = smooth(img)
    corners.map { c =>
      val (m10, m01) = moments(img, c.x, c.y)
      val bin = angleBin(m10, m01, cfg)
      Feature(c.x, c.y, bin, c.score, descriptor(smoothed, c.x, c.y, bin, cfg))
    }
  }
}
