package orb.testbench

import orb.model._
import java.io.{File, PrintWriter}

/** Compares the model's and the RTL's event lists; on a difference writes both as CSV, and the corners drawn on
  * the image, under `dumpDir/name/` for a person to look at, and returns a one-paragraph description. */
object Scoreboard {
  val dumpDir = new File("target/test-failures")

  /** When the hardware may drop items (counted), what it emitted must be the model's sequence with some left out:
    * the first emitted item that is not the model's next (out of order, or not the model's at all), if any. */
  def notAnOrderedSubset[T](model: Seq[T], emitted: Seq[T]): Option[T] = {
    var rest = model.toList
    emitted.find { e =>
      rest = rest.dropWhile(_ != e); val missing = rest.isEmpty; if (!missing) rest = rest.tail; missing
    }
  }

  /** The first place where two sequences differ (an item, or one ending first), if any. */
  def firstDifference[T](model: Seq[T], rtl: Seq[T]): Option[Int] = {
    val i = model.map(Some(_)).zipAll(rtl.map(Some(_)), None, None).indexWhere { case (a, b) => a != b }
    if (i < 0) None else Some(i)
  }

  /** A description of the first difference between two sequences of `what`, if any. */
  def describe[T](name: String, what: String, model: Seq[T], rtl: Seq[T]): Option[String] =
    firstDifference(model, rtl).map { i =>
      s"$name: model ${model.size} $what, RTL ${rtl.size}; first difference at $i: model ${model.lift(i).getOrElse("-")} " +
        s"vs RTL ${rtl.lift(i).getOrElse("-")}"
    }

  /** The directory of a case's dumps. */
  def dumpDirOf(name: String): File = {
    val dir = new File(dumpDir, name.replaceAll("[^A-Za-z0-9_.-]+", "_"))
    dir.mkdirs()
    dir
  }

  /** Model and RTL correspondences compared; on a difference both are written as CSV. */
  def compareCorrespondences(name: String, model: Seq[Correspondence], rtl: Seq[Correspondence]): Option[String] =
    describe(name, "correspondences", model, rtl).map { msg =>
      val dir = dumpDirOf(name)
      Csv.correspondences(new File(dir, "model.csv"), model)
      Csv.correspondences(new File(dir, "rtl.csv"), rtl)
      s"$msg; dumped to ${dir.getPath}"
    }

  /** Model and RTL feature streams (features and frame ends) compared; on a difference both feature lists are
    * dumped (`dumpFeatures`). */
  def compareFeatureStreams(
      name: String,
      model: Seq[Either[FrameEnd, Feature]],
      rtl: Seq[Either[FrameEnd, Feature]],
      image: Option[GrayImage] = None
  ): Option[String] =
    describe(name, "feature stream items", model, rtl).map { msg =>
      def features(s: Seq[Either[FrameEnd, Feature]]) = s.collect { case Right(f) => f }
      s"$msg; dumped to ${dumpFeatures(name, features(model), features(rtl), image)}"
    }

  def compare(
      name: String,
      model: Seq[CoreEvent],
      rtl: Seq[CoreEvent],
      image: Option[GrayImage] = None
  ): Option[String] = {
    val firstDiff = firstDifference(model, rtl) match {
      case None => return None
      case Some(i) => i
    }
    val dir = dumpDirOf(name)
    writeCsv(new File(dir, "model.csv"), model)
    writeCsv(new File(dir, "rtl.csv"), rtl)
    image.foreach { img =>
      def corners(es: Seq[CoreEvent]) = es.collect { case CornerEvent(c) => c }
      Draw.corners(img, corners(model), corners(rtl)).foreach(javax.imageio.ImageIO.write(
        _,
        "png",
        new File(dir, "corners.png")
      ))
    }
    Some(
      s"$name: model emitted ${model.size} events, RTL ${rtl.size}; first difference at event $firstDiff: " +
        s"model ${model.lift(firstDiff).getOrElse("-")} vs RTL ${rtl.lift(firstDiff).getOrElse("-")}; dumped to ${dir.getPath}"
    )
  }

  /** Both feature lists as CSV (x, y, bin, score, descriptor) under `dumpDir/name/`, with the picture of their
    * positions when the image is given; returns the directory. */
  def dumpFeatures(name: String, model: Seq[Feature], rtl: Seq[Feature], image: Option[GrayImage] = None): File = {
    val dir = dumpDirOf(name)
    for ((file, fs) <- Seq("model_features.csv" -> model, "rtl_features.csv" -> rtl)) {
      val w = new PrintWriter(new File(dir, file))
      try {
        w.println("x,y,bin,score,descriptor"); fs.foreach(f => w.println(s"${f.x},${f.y},${f.bin},${f.score},${f.hex}"))
      } finally w.close()
    }
    def corners(fs: Seq[Feature]) = fs.map(f => Corner(f.x, f.y, f.score))
    image.foreach(img =>
      Draw.corners(img, corners(model), corners(rtl)).foreach(javax.imageio.ImageIO.write(
        _,
        "png",
        new File(dir, "features.png")
      ))
    )
    dir
  }

  def writeCsv(f: File, events: Seq[CoreEvent]): Unit = {
    val w = new PrintWriter(f)
    try {
      w.println("kind,x,y,score,ok,keyframe")
      events.foreach {
        case CornerEvent(c) => w.println(s"corner,${c.x},${c.y},${c.score},,")
        case FrameEndEvent(e) => w.println(s"frame_end,,,,${e.ok},${e.keyframe}")
      }
    } finally w.close()
  }
}

/** The CSV files the tests and the tools write. */
object Csv {
  def write(f: File)(body: PrintWriter => Unit): Unit = {
    val w = new PrintWriter(f)
    try body(w)
    finally w.close()
  }

  /** `live_x,live_y,key_x,key_y,distance`, in the order given */
  def correspondences(f: File, cs: Seq[Correspondence]): Unit = write(f) { w =>
    w.println("live_x,live_y,key_x,key_y,distance")
    cs.foreach(c => w.println(s"${c.liveX},${c.liveY},${c.keyX},${c.keyY},${c.distance}"))
  }
}

/** Tiny drawing helpers for debug pictures (no plotting library needed for crosses on an image). */
object Draw {
  import java.awt.image.BufferedImage

  /** Model corners as green crosses, RTL corners as red squares: where they agree both show. */
  def corners(img: GrayImage, model: Seq[Corner], rtl: Seq[Corner]): Option[BufferedImage] = {
    val out = new BufferedImage(img.width, img.height, BufferedImage.TYPE_INT_RGB)
    for (y <- 0 until img.height; x <- 0 until img.width) {
      val v = img(x, y) / 2; out.setRGB(x, y, (v << 16) | (v << 8) | v)
    }
    def put(x: Int, y: Int, rgb: Int): Unit =
      if (x >= 0 && y >= 0 && x < img.width && y < img.height) out.setRGB(x, y, rgb)
    for (c <- model; d <- -3 to 3) { put(c.x + d, c.y, 0x00ff00); put(c.x, c.y + d, 0x00ff00) }
    for (c <- rtl; d <- -2 to 2) {
      put(c.x + d, c.y - 2, 0xff0000); put(c.x + d, c.y + 2, 0xff0000); put(c.x - 2, c.y + d, 0xff0000);
      put(c.x + 2, c.y + d, 0xff0000)
    }
    Some(out)
  }
}
