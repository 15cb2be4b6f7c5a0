package orb

import spinal.core._
import spinal.lib._
import spinal.lib.bus.avalon._
import orb.model.SystemModel

/** A bit of `CONTROL`. */
final case class ControlBit(bit: Int, name: String, meaning: String, reset: OrbConfig => Boolean)

/** One 32-bit register of the Avalon-MM slave. A parameter (`rw`) is a register of `width` bits read back as
  * written; a counter or a constant (`r`) is read from the core: `hardware` gives its value in `OrbTop`, `model` the
  * golden model's value after a run, when the model has it. */
final case class Register(
    name: String,
    address: Int,
    writable: Boolean,
    meaning: String,
    width: OrbConfig => Int = _ => 32,
    reset: OrbConfig => BigInt = _ => 0,
    bits: Seq[ControlBit] = Nil,
    hardware: Option[OrbTop => UInt] = None,
    model: Option[SystemModel.Result => Long] = None
) {

  /** the name in `summary.json` and the testbenches */
  def key: String = name.toLowerCase
  def access: String = if (writable) "rw" else "r"
}

/** The register map: the one table that the slave is built from, that the testbenches and `Match` name the
  * counters by, and that the README's table is written from (`markdown`; a test compares them). */
object RegisterMap {

  /** version 3: the feature budget (2: the segment test, 1: the first map) */
  val version = 3

  /** "ORB" and the version */
  val id: BigInt = BigInt("4f5242", 16) * 256 + version
  val config: AvalonMMConfig = AvalonMMSlaveFactory.getAvalonConfig(addressWidth = 8, dataWidth = 32)

  /** clocks from a read to its data (`readDataValid`): the address decoded into a register, then each group of
    * sources' selected value (`readGroup` sources a group), then the data */
  val readLatency = 3

  /** read sources ORed into one register before the groups are ORed into the data: two, a LUT4 per bit (the
    * counters come from across the chip straight into it) */
  val readGroup = 2

  val RATIO_TEST = ControlBit(0, "ratio test", "ratio test on (from the next frame)", _.matcher.defaultRatioTest)
  val CROSS_CHECK = ControlBit(1, "cross-check", "cross-check on (from the next frame)", _.matcher.defaultCrossCheck)
  val SEGMENT_TEST = ControlBit(2, "segment test", "segment test on (at once)", _.harris.segment.isDefined)

  val ID = Register(
    "ID",
    0x00,
    writable = false,
    s"\"ORB\", register map version $version (version 2 had no feature budget, version 1 no segment test)",
    reset = _ => id,
    hardware = Some(_ => U(id, 32 bits))
  )
  val CONTROL = Register(
    "CONTROL",
    0x04,
    writable = true,
    "",
    width = _ => 3,
    reset = c => Seq(RATIO_TEST, CROSS_CHECK, SEGMENT_TEST).filter(_.reset(c)).map(b => BigInt(1) << b.bit).sum,
    bits = Seq(RATIO_TEST, CROSS_CHECK, SEGMENT_TEST)
  )
  val HARRIS_THRESHOLD = Register(
    "HARRIS_THRESHOLD",
    0x08,
    writable = true,
    "the minimum score: a candidate is a corner when its score is above this (and it wins the 3x3 suppression)",
    reset = c => c.harris.defaultThreshold
  )
  val HAMMING_THRESHOLD = Register(
    "HAMMING_THRESHOLD",
    0x0c,
    writable = true,
    "accept a best match at this distance or less (0..256)",
    width = _ => MatcherConfig.distanceWidth,
    reset = _.matcher.defaultHammingThreshold
  )
  val RATIO = Register(
    "RATIO",
    0x10,
    writable = true,
    "ratio-test factor r x 256 (205 = 0.8; up to 511)",
    width = _.matcher.ratioWidth,
    reset = _.matcher.defaultRatio
  )
  val SEGMENT_THRESHOLD = Register(
    "SEGMENT_THRESHOLD",
    0x14,
    writable = true,
    "the segment test's t (0..255): a candidate needs 9 contiguous circle pixels beyond centre +- t",
    width = _ => 8,
    reset = _.harris.segment.fold(0)(_.defaultThreshold)
  )
  val TARGET = Register(
    "TARGET",
    0x18,
    writable = true,
    "the feature budget's target: features per frame (0..65535; the cut for it is learnt from the last good frame)",
    width = _ => BudgetConfig.targetWidth,
    reset = _.budget.defaultTarget
  )
  val FRAMES = Register(
    "FRAMES",
    0x20,
    writable = false,
    "start-of-frame markers seen",
    hardware = Some(_.core.io.status.frames),
    model = Some(_.core.counters.frames)
  )
  val BAD_FRAMES = Register(
    "BAD_FRAMES",
    0x24,
    writable = false,
    "frames with a geometry fault",
    hardware = Some(_.core.io.status.badFrames),
    model = Some(_.core.counters.badFrames)
  )
  val BAD_LINES = Register(
    "BAD_LINES",
    0x28,
    writable = false,
    "lines of the wrong length",
    hardware = Some(_.core.io.status.badLines),
    model = Some(_.core.counters.badLines)
  )
  val CORNERS = Register(
    "CORNERS",
    0x2c,
    writable = false,
    "Harris corners",
    hardware = Some(_.core.io.status.corners),
    model = Some(_.core.cornerCount)
  )
  val FEATURES = Register(
    "FEATURES",
    0x30,
    writable = false,
    "features (keyframe and live)",
    hardware = Some(_.core.io.status.features),
    model = Some(_.core.features.size.toLong)
  )
  val FEATURE_DROPS = Register(
    "FEATURE_DROPS",
    0x34,
    writable = false,
    "selected corners that got no feature: a fault cut their rows, or (never by design) a consumer held the features too long",
    hardware = Some(_.core.io.status.featureDrops),
    model = Some(_.core.featureDrops)
  )
  val STORED = Register(
    "STORED",
    0x38,
    writable = false,
    "features in the store now",
    hardware = Some(_.matcher.io.status.stored),
    model = Some(_.matches.store.features.size.toLong)
  )
  val STORE_OVERFLOW = Register(
    "STORE_OVERFLOW",
    0x3c,
    writable = false,
    "keyframe features beyond the capacity",
    hardware = Some(_.matcher.io.status.storeOverflow),
    model = Some(_.matches.overflow)
  )
  val MATCHES = Register(
    "MATCHES",
    0x40,
    writable = false,
    "correspondences put out",
    hardware = Some(_.matcher.io.status.matches),
    model = Some(_.correspondences.size.toLong)
  )
  val MATCH_DROPS = Register(
    "MATCH_DROPS",
    0x44,
    writable = false,
    "correspondences lost to a stalled consumer",
    hardware = Some(_.matcher.io.status.matchDrops),
    model = Some(_ => 0L)
  )
  val DESELECTED = Register(
    "DESELECTED",
    0x48,
    writable = false,
    "corners the feature budget did not select (beaten in their cell, or past the frame's cut or target)",
    hardware = Some(_.core.io.status.deselected),
    model = Some(_.core.deselected)
  )

  val all: Seq[Register] = Seq(
    ID,
    CONTROL,
    HARRIS_THRESHOLD,
    HAMMING_THRESHOLD,
    RATIO,
    SEGMENT_THRESHOLD,
    TARGET,
    FRAMES,
    BAD_FRAMES,
    BAD_LINES,
    CORNERS,
    FEATURES,
    FEATURE_DROPS,
    STORED,
    STORE_OVERFLOW,
    MATCHES,
    MATCH_DROPS,
    DESELECTED
  )

  /** the counters, in address order */
  val counters: Seq[Register] = all.filter(_.model.isDefined)
  require(all.map(_.address).distinct.size == all.size && all.forall(_.address % 4 == 0), "one register per word")
  require(all.map(_.address).max < (1 << config.addressWidth))

  def meaning(r: Register): String =
    if (r.bits.isEmpty) r.meaning else r.bits.map(b => s"bit ${b.bit}: ${b.meaning}").mkString(", ")

  /** The README's table for a configuration (the default's reset values). */
  def markdown(cfg: OrbConfig): String = {
    def reset(r: Register): String =
      if (r.bits.nonEmpty) "0b" + r.reset(cfg).toString(2)
      else if (r == ID) "0x" + r.reset(cfg).toString(16)
      else r.reset(cfg).toString
    ("| address | name | access | reset | meaning |" +: "|---|---|---|---|---|" +: all.map { r =>
      f"| 0x${r.address}%02x | ${r.name} | ${r.access} | ${reset(r)} | ${meaning(r)} |"
    }).mkString("\n")
  }
}

/** The Avalon-MM slave of `RegisterMap`: the parameters as registers, a read's address decoded into a register, the
  * selected source of each pair of them into a register (the counters' own registers across the chip feed one
  * LUT level: no copies of them beside the bus), the groups ORed into the data (`RegisterMap.readLatency`).
  * Writes take effect a clock after they are accepted. */
class RegisterFile(bus: AvalonMM, cfg: OrbConfig, top: OrbTop) extends Area {
  import RegisterMap._
  bus.waitRequestn := True
  val parameters: Map[Register, UInt] = all.filter(_.writable).map { r =>
    val value = Reg(UInt(r.width(cfg) bits)) init r.reset(cfg)
    value.setName(s"regs_${r.key}")
    when(bus.write && bus.address === r.address) {
      value := bus.writeData.asUInt.resize(r.width(cfg))
    }
    r -> value
  }.toMap
  def apply(r: Register): UInt = parameters(r)
  def apply(b: ControlBit): Bool = parameters(CONTROL)(b.bit)

  val sources: Seq[(Register, UInt)] = all.map { r =>
    r -> parameters.getOrElse(r, r.hardware.get(top).resize(32))
  }
  val selected = RegNext(Vec(sources.map { case (r, _) => bus.read && bus.address === r.address }))
  val reading = RegNext(bus.read) init False
  val groups = selected.zip(sources.map(_._2.resize(32).asBits)).grouped(readGroup).toSeq.map { g =>
    RegNext(MuxOH.or(g.map(_._1), g.map(_._2)))
  }
  bus.readData := RegNext(groups.reduce(_ | _))
  bus.readDataValid := RegNext(RegNext(reading) init False) init False
}
