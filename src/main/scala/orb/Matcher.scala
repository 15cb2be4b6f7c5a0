package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.keptApart

/** Keyframe store and brute-force Hamming matcher, as `orb.model.MatcherModel`.
  *
  * Input: the feature stream with its frame-end items. A frame whose items carry `keyframe` replaces the store with its
  * strongest `storeCapacity` features by the rank of their scores (`FeatureHw.rank`; appended one per clock; once full,
  * a stronger feature replaces the weakest entry and a rescan of the ranks, P per clock, finds the next weakest). Every
  * other frame's feature is compared with the whole store, `comparators` entries per clock: lane l holds entries l,
  * l + P, l + 2P, ... in its own RAM, so a scan reads one group of P entries per clock. Each lane computes the Hamming
  * distance (xor, popcount tree pipelined every `popcountLevelsPerStage` adder levels); the lanes are merged into best
  * (first on ties) and second best, consecutive groups merged in pairs, and the pairs accumulated. The feature is held
  * (input not ready) for `MatcherConfig.clocksPerFeature` clocks.
  *
  * Cross-check (mutual nearest neighbours, OpenCV's BFMatcher crossCheck): every entry keeps the best live
  * feature of the frame so far (distance, position, and whether that live feature's own best is this entry). A
  * live feature that beats an entry's distance (strictly: the first on ties) takes it over during its scan; when
  * its scan ends, its best entry is marked mutual if it took that entry over and the match is accepted. At the
  * frame's end item the entries are read in store order: the mutual ones are emitted (so cross-checked
  * correspondences come at the end of the frame, in keyframe order) and every entry is cleared, one per clock.
  * Without cross-check a correspondence leaves as soon as its scan ends, in live order.
  *
  * Output: a FIFO of `outputDepth`. The matcher paces itself to a slow consumer (it takes the next item, and the
  * sweep reads the next entry, only when the FIFO has room), so nothing is lost to a consumer that is merely
  * slower than one per clock. When the FIFO has been full for `outputTimeout` clocks (a stalled consumer) it stops
  * waiting and drops, and counts, what does not fit until the consumer takes one again: the feature stream keeps
  * flowing, so later frames are still matched.
  *
  * The input's contract (the descriptor unit's output register keeps it): an offered item stays, unchanged, until it
  * is taken and in the clock after its take, its descriptor in the clock after that too, and no item is offered in
  * those two clocks. The matcher reads the taken feature there (a replacement writes it a clock after its take, the
  * live descriptor's copies load it up to two clocks after) and has no input register of its own; it takes an
  * item the clock after it is first offered at the earliest (its kind registered by then), deciding the take from its
  * own registers (an item offered and not taken is offered in the next clock: the sender's valid is not read then). */
class Matcher(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig, m: MatcherConfig) extends Component {
  import MatcherConfig.{crossLatency, decideLatency, distanceWidth, none, pushLatency, readLatency}
  val io = new Bundle {
    val features = slave Stream (FeatureHw(f, h, d))
    val params = in(MatchParamsHw(m))
    val correspondences = master Stream (CorrespondenceHw(f))
    val status = out(MatcherStatus(f))
  }
  val P = m.comparators
  val cw = f.coordWidth
  val rankWidth = MatcherConfig.rankWidth(h)
  val groupWidth = log2Up(m.groups max 2)
  val countWidth = log2Up(m.storeCapacity + 1)

  case class Entry() extends Bundle {
    val x, y = UInt(cw bits)
    val descriptor = Bits(OrbDescriptorConfig.descriptorBits bits)
  }

  case class Position() extends Bundle {
    val x, y = UInt(cw bits)
  }

  /** per entry: the best live feature of this frame so far */
  case class Cross() extends Bundle {
    val distance = UInt(distanceWidth bits) // `none` until a live feature has been compared
    val mutual = Bool()
    val liveX, liveY = UInt(cw bits)
  }

  /** entry index -> group (the RAM address of its lane), as a slice: plain Verilog without width warnings */
  def groupOf(index: UInt, width: Int): UInt = (if (P == 1) index else index(index.high downto log2Up(P))).resize(width)
  def laneIs(lane: UInt, l: Int): Bool = if (P == 1) True else lane === l
  require(
    rankWidth <= distanceWidth + 1 + 2 * cw,
    "a rank must fit the cross word it borrows while a keyframe loads"
  )
  def clearedCross: Cross = { val c = Cross(); c.distance := none; c.mutual := False; c.liveX := 0; c.liveY := 0; c }

  // The input port itself, no register of its own: the contract (above) keeps a taken item a clock after its take (its
  // descriptor two), where the load and the scan's copies read it. A take is two registers' AND (`ready` and `waiting`,
  // below), not the sender's valid: an item offered in the last clock and not taken then is offered now (a stream's
  // valid holds until its take), so no decision at a take waits for a wire from the other block.
  val item = io.features
  val isKey = item.keyframe
  val waiting = Reg(Bool()) init False
  val take = Bool()

  /** copies of the handshake's two registers (kept apart, set beside `ready` and `waiting` below) for one group of
    * decisions at a take: each is then one LUT of registers (the copies' and the kind's), not a second level behind
    * the take, whose one LUT drives the frame state and the input's readiness */
  class Handshake extends Area {
    val ready = keptApart(Reg(Bool()) init True)
    val waiting = keptApart(Reg(Bool()) init False)
    def take: Bool = ready && waiting
  }

  /** the keyframe features' decisions (the load), the live features' (the scan's start) and the frame ends' */
  val takes = new Area {
    val key = new Handshake
    val live = new Handshake
    val ends = new Handshake
    def all: Seq[Handshake] = Seq(key, live, ends)
  }

  // Frame state: the first item of a frame samples the parameters and, on a keyframe, empties the store.
  val frame = new Area {
    val first = Reg(Bool()) init True
    val key = Reg(Bool()) init False
    val params = Reg(MatchParamsHw(m))
    params.hammingThreshold init m.defaultHammingThreshold
    params.ratio init m.defaultRatio
    params.ratioTest init Bool(m.defaultRatioTest)
    params.crossCheck init Bool(m.defaultCrossCheck)
    when(take) {
      first := item.end.now
      when(first) {
        key := isKey
        params := io.params
      }
    }
  }

  // The offered item's kind, registered while it waits: an item is taken no earlier than the clock after it is first
  // offered (`waiting`), so each decision at a take is one LUT of registers (the handshake's and the kind's), not the
  // frame state and the item's flags through two levels. The frame state is up to date as an item is first offered
  // (it changes as an item is taken, and none is offered in the clock after a take: the input's contract).
  val kind = new Area {
    val keyNow = Mux(frame.first, isKey, frame.key)
    val keyFeature = RegNext(keyNow && !item.end.now)
    val liveFeature = RegNext(!keyNow && !item.end.now)
    val keyEnd = RegNext(keyNow && item.end.now)
    val liveEnd = RegNext(!keyNow && item.end.now)

    /** the keyframe's first item: it empties the store */
    val emptiesStore = RegNext(frame.first && isKey)
  }

  /** What the matcher is doing, one thing at a time: an item is taken only when it is idle (and a rescan's start or
    * a sweep's last clears are not pending). */
  object Activity extends SpinalEnum(binaryOneHot) {
    val IDLE, SCAN, RESCAN, SWEEP, KEY_END = newElement()
  }
  val activity = RegInit(Activity.IDLE)

  /** the conditions on which an activity ends (back to idle), each from `endsOn`: the readiness reads them all */
  val ending = scala.collection.mutable.ArrayBuffer[Bool]()
  def endsOn(cond: Bool): Unit = {
    ending += cond
    when(cond) {
      activity := Activity.IDLE
    }
  }

  val stored = Reg(UInt(countWidth bits)) init 0
  val storedNow = Mux(kind.emptiesStore, U(0, countWidth bits), stored)
  // stored + 1 in a register beside it: the count changes only as a keyframe feature is taken, and items are at
  // least two clocks apart (the input's contract), so the next one finds it up to date (no incrementer after the
  // handshake)
  val storedPlusOne = RegNext(stored + 1) init 1
  // The groups a scan reads: enough for the stored entries, rounded up to an even count (the accumulation takes
  // them in pairs; a group beyond the stored entries holds none that is real (`index < stored`): stale entries, or
  // with an odd number of groups in the capacity a word past the RAMs' last, read and ignored). Registered: the store only
  // changes while a keyframe loads, a clock or more before a scan starts (its end item keeps the matcher busy for
  // at least a clock); so are the comparisons a scan makes with the count of groups: those it starts with from
  // `stored`, those it uses from its second clock on from `groups`
  val groups = RegNext(groupOf(stored +^ (2 * P - 1), groupWidth + 1) & ~U(1, groupWidth + 1 bits)) init 0
  val groupsCompared = new Area {
    val zero = RegNext(stored === 0) init True
    val lessOne = RegNext((groups - 1).resize(groupWidth)) init 0
    val lessTwo = RegNext(groups - 2) init 0
  }

  val entryWidth = widthOf(Entry())
  val partWidth = (entryWidth + MatcherConfig.storeParts - 1) / MatcherConfig.storeParts

  /** A part of a lane's entries: its own RAM blocks, read and written through registers of its own (kept apart:
    * one address or enable register would drive all of a lane's blocks). */
  class StorePart extends Area {
    val ram = Mem(Bits(partWidth bits), m.groups)

    /** the word at `address` (registered before the RAM), through the RAM's output register */
    def read(address: UInt): Bits = RegNext(ram.readSync(keptApart(RegNext(address))))

    /** `data` (plain registers) written at `address` when `enable`, both registered before the RAM */
    def write(address: UInt, data: Bits, enable: Bool): Unit =
      ram.write(keptApart(RegNext(address)), data, keptApart(RegNext(enable) init False))
  }
  val lanes =
    for (l <- 0 until P) yield new Area {
      // the lane's entries in parts, each with registers of its own (`StorePart`)
      val store = Seq.fill(MatcherConfig.storeParts)(new StorePart)
      // While a keyframe loads, an entry's cross state is not needed: its word holds the entry's rank instead
      // (what the replacement compares), and the keyframe's end clears them all (no RAM for the ranks).
      val cross = Mem(Cross(), m.groups)
    }

  // The weakest entry of a full store (lowest rank, the first on ties): the one a stronger feature replaces.
  val weakest = new Area {
    val rank = Reg(UInt(rankWidth bits)) init 0
    val index = Reg(UInt(countWidth bits)) init 0
  }

  // Keyframe features: appended while there is room (keeping track of the weakest), then each one stronger than
  // the weakest replaces it, after which a rescan of the ranks finds the new weakest. Every feature beyond the
  // capacity, kept or not, costs one: counted as overflow.
  val load = new Area {
    val keyFeature = takes.key.take && kind.keyFeature
    // the store's count tested in registers a clock late: it changes only as a keyframe feature is taken, and items
    // are at least two clocks apart (the input's contract), so the next one meets the tests of the count it left
    val emptied = kind.emptiesStore
    // full: the count at the capacity, a register that changes with the count (from a register beside the count
    // that compares it with one less), so the next item's append test (`appendLanes`) compares no count
    val full = Reg(Bool()) init False
    val almostFull = RegNext(stored === m.storeCapacity - 1) init Bool(m.storeCapacity == 1)
    val room = emptied || !full
    val storedZero = emptied || groupsCompared.zero
    val append = keyFeature && room

    /** a keyframe feature meets the full store: counted as overflow, kept only if it replaces the weakest */
    val meetsFull = keyFeature && !room

    /** a keyframe feature met the full store in the last clock: it replaces the weakest entry if it is stronger,
      * compared in the clock of the take (into registers, every clock) and decided now from registers: no
      * comparison between the handshake or the ranks and the store's enables. The input still holds it (the
      * input's contract), and the weakest has not changed since (it changes a clock after an append, or at a
      * rescan's end, both at least a clock before a take). */
    val metFull = RegNext(meetsFull) init False
    // The offered rank copied every clock beside the comparisons: at a take it holds the taken item's (offered
    // in the clock before, `waiting`, and unchanged since), so no comparison starts from the sender's register.
    val offeredRank = RegNext(item.rank)
    // compared in parts side by side into registers, combined after them (no carry through the whole rank)
    val strongerParts =
      RegNext(Arith.comparedInParts(offeredRank, weakest.rank, orEqual = false, MatcherConfig.rankParts))
    val stronger = Arith.combineParts(strongerParts)
    val replace = metFull && stronger
    // The weakest entry's place whenever a feature met the full store (no append then: items are two clocks apart),
    // written only if it replaces: the comparison reaches the enables, not the address. Both places are registers
    // formed a clock ahead, so the choice is the only logic before the parts' copies: the count does not change in
    // the clock before a take, the kind is its register's next value, and the weakest as `weakestLanes` below.
    val appendAddr = RegNext(groupOf(Mux(kind.emptiesStore.getAheadValue(), U(0, countWidth bits), stored), groupWidth))
    val replaceAddr = RegNext(groupOf(weakest.index, groupWidth))
    val addr = Mux(metFull, replaceAddr, appendAddr)
    // Each lane's write decided from registers of the lanes the count and the weakest name, a clock behind them:
    // the count changes only as a feature is taken (items at least two clocks apart), the weakest at the latest as
    // a take's clock begins, and a replacement is decided a clock after its take; so no index is chosen and
    // compared on the way to a lane's enable.
    val laneBits = log2Up(P) max 1
    val weakestLanes = Vec((0 until P).map(l => RegNext(laneIs(weakest.index.resize(laneBits), l)) init Bool(l == 0)))

    // Whether the item offered now would be appended to lane `l` if taken (`append` without the take, and the lane
    // the count names): a register per lane from the next values of the kind and of the count's tests, the same
    // values a clock ahead, so a lane's enable is the take and one register (or the replacement's registers)
    val emptiesNext = kind.emptiesStore.getAheadValue()
    val appendsNext = kind.keyFeature.getAheadValue() && (emptiesNext || !full)
    val appendLanes = Vec((0 until P).map { l =>
      val laneNext = Mux(emptiesNext, Bool(l == 0), laneIs(stored.resize(laneBits), l))
      RegNext(appendsNext && laneNext) init False
    })

    /** a write (an append or a replacement) for lane `l`: the two never come in the same clock */
    def writes(l: Int): Bool = (takes.key.take && appendLanes(l)) || (replace && weakestLanes(l))
    val overflow = meetsFull
    when(takes.key.take && kind.emptiesStore) {
      stored := 0
      full := False
    }
    when(append) {
      stored := Mux(kind.emptiesStore, U(1, countWidth bits), storedPlusOne)
      full := Mux(kind.emptiesStore, Bool(m.storeCapacity == 1), almostFull)
    }
    // an appended feature that becomes the weakest: compared as it is taken (its rank below the weakest's, in parts
    // into registers, as `strongerParts`), decided and written a clock later (the next item is taken two clocks
    // after at the earliest: the input's contract), so no carry chain or handshake drives the weakest entry's enables
    val appended = RegNext(append) init False
    val appendedToEmpty = RegNext(storedZero)
    val weakerParts =
      RegNext(Arith.comparedInParts(weakest.rank, offeredRank, orEqual = false, MatcherConfig.rankParts))
    val becomesWeakest = appended && (appendedToEmpty || Arith.combineParts(weakerParts))
    val appendedRank = RegNext(item.rank)
    val appendedIndex = RegNext(storedNow)
    when(becomesWeakest) {
      weakest.rank := appendedRank
      weakest.index := appendedIndex
    }
  }

  // After a replacement: all ranks read, P per clock, and the lowest (first on ties) becomes the weakest.
  val rescan = new Area {
    def busy: Bool = activity === Activity.RESCAN
    val group = Reg(UInt(groupWidth + 1 bits)) init 0
    val issuing = busy && group < m.groups
    when(issuing) { group := group + 1 }
    // a clock after the replacement: its rank reaches the RAM two clocks after it, before the first read does
    val starting = RegNext(load.replace) init False
    when(starting) {
      activity := Activity.RESCAN
      group := 0
    }
  }

  // Live features: the scan over the store, one group per clock.
  val scan = new Area {
    def busy: Bool = activity === Activity.SCAN
    val group = Reg(UInt(groupWidth + 1 bits)) init 0

    /** the live feature's position (its descriptor: `compare.liveCopies`) */
    val live = Reg(Position())

    /** a group is read now (`busy` and `group < groups`), a register: whether the group read now is the last one is
      * compared a clock ahead */
    val issuing = Reg(Bool()) init False
    val lastGroup = Reg(Bool()) init False
    when(issuing) {
      group := group + 1
      issuing := !lastGroup
      lastGroup := group === groupsCompared.lessTwo
    }
    val start = takes.live.take && kind.liveFeature
    when(start) {
      activity := Activity.SCAN
      group := 0
      issuing := !groupsCompared.zero
      lastGroup := False // two groups or none
    }
    // copied every clock while idle (an enable from one register, not from the handshake): the feature that starts
    // the scan is the last one copied
    when(!busy) {
      live.x := item.x
      live.y := item.y
    }
    val readAddr = group.resize(groupWidth)
  }

  val output = StreamFifo(CorrespondenceHw(f), m.outputDepth, forFMax = true)
  // Waiting for the consumer, with a limit. The room is judged from the last clock's free places (at most one push
  // a clock takes one away), compared in registers, so no decision waits for the FIFO's pointers or a comparison.
  val paced = new Area {

    /** the entry read now is pushed `pushLatency` clocks later, after the pushes of the reads in flight and of the one
      * the last clock's free places do not show yet: with fewer free places than that, the sweep has to wait */
    val tight = RegNext(output.io.availability < pushLatency + 2) init False

    /** a scan's correspondence (pushed when the scan ends, with nothing else pushed meanwhile) will fit: judged on
      * the free places of two clocks ago (what one push in flight and one in the last clock can have taken) */
    val roomForItem = RegNext(output.io.availability >= 3) init True
    val waited = Reg(UInt(log2Up(m.outputTimeout + 1) bits)) init 0

    /** waited === outputTimeout - 1, a register beside the count: the readiness reads the next `giveUp` (below),
      * which then tests no count */
    val lastWait = Reg(Bool()) init Bool(m.outputTimeout == 1)

    /** waited === outputTimeout, kept in its own register */
    val giveUp = Reg(Bool()) init False
    when(!tight) {
      waited := 0
      lastWait := Bool(m.outputTimeout == 1)
      giveUp := False
    } elsewhen (!giveUp) {
      waited := waited + 1
      lastWait := (if (m.outputTimeout >= 2) waited === m.outputTimeout - 2 else True)
      giveUp := lastWait
    }
    val sweepRoom = !tight || giveUp
  }

  // Frame end of a live frame: every entry read in store order, the mutual ones emitted, all cleared.
  val sweep = new Area {
    def busy: Bool = activity === Activity.SWEEP
    val entry = Reg(UInt(countWidth bits)) init 0

    /** entry < stored, a register beside the entry (the store does not change during a live frame's sweep) */
    val more = Reg(Bool()) init False

    /** entry + 1, a register beside it: `more` compares it with the count, no incrementer before the comparison */
    val following = Reg(UInt(countWidth bits)) init 1
    val reading = busy && more && paced.sweepRoom
    when(reading) {
      entry := following
      following := following + 1
      more := following < stored
    }
    endsOn(busy && !more)
    when(takes.ends.take && kind.liveEnd) {
      activity := Activity.SWEEP
      entry := 0
      following := 1
      // the count's test in its register (a live frame does not change the count; the keyframe's last take was two
      // clocks or more before)
      more := !groupsCompared.zero
    }
    val lane = entry.resize(log2Up(P) max 1)
    val addr = groupOf(entry, groupWidth)

    /** reads whose clear has not been written yet: the next feature's scan must not read their words before */
    val drains = (1 to crossLatency + 1).map(k => Delay(reading, k, init = False))
    val draining = drains.reduce(_ || _)

    /** `draining` in the next clock */
    val drainingNext = (reading +: drains.init).reduce(_ || _)
  }

  // Frame end of a keyframe: the ranks in the cross words are replaced by cleared cross state, a group per clock.
  val keyEnd = new Area {
    def busy: Bool = activity === Activity.KEY_END
    val group = Reg(UInt(groupWidth + 1 bits)) init 0

    /** `group` is the store's last: a register beside the count, so the activity's next value waits for no compare */
    val atLast = Reg(Bool()) init False
    when(busy) {
      group := group + 1
      atLast := (if (m.groups >= 2) group === m.groups - 2 else True)
    }
    endsOn(busy && atLast)
    when(takes.ends.take && kind.keyEnd) {
      activity := Activity.KEY_END
      group := 0
      atLast := Bool(m.groups == 1)
    }

    /** the clears a clock behind the activity, a flag per lane (kept apart): no activity flag reaches a lane's write
      * data. The next item's first write (a keyframe feature's rank word) still comes after the last clear. */
    val clears = Seq.fill(P)(keptApart(RegNext(busy) init False))

    val clearGroup = RegNext(group.resize(groupWidth))
  }

  val popStages = MatcherConfig.popcountStages(m)

  // The read side of every lane: store and cross state, by the scan, the sweep or the rescan, every clock (a read
  // nobody asked for is ignored), through a lane's own address registers and the RAMs' output registers: the entries
  // come `readLatency` clocks after the address is chosen, the cross words (a plain register more) `crossLatency`.
  // The scan reads a group's cross state later than its entries, so that it meets their distance (the address
  // waits, not the data).
  require(popStages >= crossLatency - readLatency, "the cross word's address waits for the entry's distance")
  val scanCrossAddr = Delay(scan.readAddr, popStages - (crossLatency - readLatency))
  val reads =
    for ((lane, l) <- lanes.zipWithIndex) yield new Area {
      // each lane's own copies (kept apart: one register would drive every RAM of the store)
      def address(scanAddr: UInt): UInt =
        Mux(rescan.busy, rescan.group.resize(groupWidth), Mux(sweep.busy, sweep.addr, scanAddr))
      val crossAddr = keptApart(RegNext(address(scanCrossAddr)))
      // each part through its own address copy and its RAMs' output register
      val entry = Entry()
      entry.assignFromBits(Cat(lane.store.map(_.read(address(scan.readAddr)))).resize(entryWidth))
      val crossRead = RegNext(lane.cross.readSync(crossAddr))
      val cross = RegNext(crossRead)
    }

  // The rescan's data path: the ranks read through the cross port, the lowest (first on ties) of them all.
  val rescanMin = new Area {
    // Registered at every step: the RAM data (its output register, then a register beside the comparisons: the
    // RAMs are far apart), each level of the group's lowest, the running lowest; no path holds two of them.
    val ranks = reads.map(r => RegNext(r.cross.asBits.resize(rankWidth).asUInt))
    val read = Delay(rescan.issuing, crossLatency + 1, init = False)
    val base = Delay(rescan.group.resize(countWidth) |<< log2Up(P), crossLatency + 1)
    val first = Delay(rescan.issuing && rescan.group === 0, crossLatency + 1, init = False)
    // the group's lowest rank, the first lane on ties, in four registered steps: every pair of lanes compared side
    // by side, in parts (no carry through a whole rank in one clock), the parts combined, the lane below every lane
    // before it and not above any after it picked (an AND of registered comparisons), then its rank selected: no
    // comparison waits for a choice, no choice for a comparison or a pick. Only the pairs of a lane with an earlier
    // one are compared: the picks need no other.
    val values = ranks.map(s => Delay(s, 3))
    def below(i: Int, j: Int): Bool = {
      require(j < i)
      val parts = Arith.comparedInParts(ranks(j), ranks(i), orEqual = false, MatcherConfig.rankParts)
      RegNext(Arith.combineParts(RegNext(parts)))
    }
    val belowEarlier = (0 until P).map(i => (0 until i).map(j => below(i, j)))
    val picks = RegNext(Vec((0 until P).map { i =>
      ((0 until i).map(j => belowEarlier(i)(j)) ++ (i + 1 until P).map(j => !belowEarlier(j)(i))).foldLeft(True)(_ && _)
    }))
    val low = RegNext(MuxOH.or(picks, values))
    val levels = 4
    val index = Delay(base, levels) | RegNext(OHToUInt(picks)).resize(countWidth)
    val valid = Delay(read, levels, init = False)
    val firstD = Delay(first, levels, init = False)
    val odd = Delay(rescan.group.lsb, crossLatency + 1 + levels)

    /** the group's result is the rescan's last (no read follows it) */
    val lastGroup = valid && !Delay(read, levels - 1, init = False)
    // Consecutive groups' lowest taken in pairs, as the scan does: an even group held, then the odd one after it
    // (an even last group alone, a clock later, as if its partner came); the pair's comparison registered, its
    // choice a clock later; the running lowest then takes a pair every other clock, its comparison registered before
    // its choice: no comparison and choice of one loop share a clock.
    val held = RegNext(low)
    val heldIndex = RegNext(index)
    val partnered = valid && odd
    val alone = RegNext(valid && !odd && lastGroup) init False
    val pairing = new Area {
      val valid = RegNext(partnered || alone) init False
      val first = RegNext((partnered || alone) && RegNext(firstD)) init False
      val last = RegNext((partnered && lastGroup) || alone) init False
      val a = RegNext(held)
      val aIndex = RegNext(heldIndex)
      val b = RegNext(low)
      val bIndex = RegNext(index)
      // the later group only when strictly lower (the first on ties)
      val takeB = RegNext(partnered && low < held)
    }
    val candidate = new Area {
      val valid = RegNext(pairing.valid) init False
      val first = RegNext(pairing.first) init False
      val last = RegNext(pairing.last) init False
      val rank = RegNext(Mux(pairing.takeB, pairing.b, pairing.a))
      val index = RegNext(Mux(pairing.takeB, pairing.bIndex, pairing.aIndex))
    }
    val accRank = Reg(UInt(rankWidth bits))
    val accIndex = Reg(UInt(countWidth bits))
    val choose = new Area {
      val valid = RegNext(candidate.valid) init False
      val last = RegNext(candidate.last) init False
      val takes = RegNext(candidate.first || candidate.rank < accRank)
      val rank = RegNext(candidate.rank)
      val index = RegNext(candidate.index)
    }
    when(choose.valid && choose.takes) {
      accRank := choose.rank
      accIndex := choose.index
    }
    // busy until the new weakest is in place, so that the next keyframe feature compares against it: a clock after
    // the last pair's choice
    val last = RegNext(choose.last) init False
    endsOn(last)
    when(last) {
      weakest.rank := accRank
      weakest.index := accIndex
    }
  }

  // The compare pipeline, stage by stage, side-band data delayed alongside.
  val compare = new Area {
    val valid0 = Delay(scan.issuing, readLatency, init = False)
    val group0 = Delay(scan.readAddr, readLatency)
    val valid = Delay(valid0, popStages, init = False)
    val group = Delay(group0, popStages)

    /** per lane, whether its entry of the group is in the store: compared as the group is read (the store's count
      * does not change during a scan) and delayed with the distance, a register beside the lane (no comparison with
      * the count before the merge) */
    val reals = (0 until P).map { l =>
      val index = (group0.resize(countWidth) |<< log2Up(P)) | U(l, countWidth bits)
      Delay(RegNext(index < stored), popStages - 1)
    }
    case class Lane() extends Bundle {
      val distance = UInt(distanceWidth bits)
      val index = UInt(countWidth bits)
      val wins = Bool()
    }
    // A copy of the live descriptor per `lanesPerLiveCopy` lanes (kept apart, beside their RAMs: one copy would
    // drive all the lanes' comparisons across the chip), copied while the scan is idle as `scan.live` is, in parts,
    // each by an enable from its own copy of the idle flag (no one flag drives every bit), which copies the copy's
    // flag (kept apart: no one register drives every part's). The parts' flags are two clocks late (from the
    // activity register through the copy's flag): a scan starts the clock after its take, and the taken feature's
    // descriptor stays in the input for two clocks after the take (the input's contract), so the last part loaded
    // before a scan holds it; the first entry it meets is read `readLatency` clocks after the scan starts (at least
    // two: the parts are settled by then). From two clocks after a scan until the next the parts load every clock,
    // so a keyframe feature's descriptor is in them in the clock after its take (an append's write) and the next (a
    // replacement's): a keyframe feature is taken at least three clocks after a live frame's end item.
    // The copy's position (what its lanes write of the live feature: the cross state's, a keyframe entry's) loads
    // by the copy's flag, a clock earlier than the parts: the input holds it a clock after its take, so the copy
    // holds the taken feature's from two clocks after the take (a replacement's write, a scan's first take-over
    // later still) and a keyframe feature's in the clock after its take.
    require(readLatency >= 2, "the live descriptor's copies settle two clocks after a scan's take")
    class LiveCopy extends Area {
      val partBits = item.descriptor.getWidth / MatcherConfig.liveDescriptorParts
      val copyIdle = keptApart(RegNext(activity =/= Activity.SCAN) init True)
      val parts = (0 until MatcherConfig.liveDescriptorParts).map { i =>
        val idle = keptApart(RegNext(copyIdle) init True)
        val part = keptApart(Reg(Bits(partBits bits)))
        when(idle) {
          part := item.descriptor(i * partBits, partBits bits)
        }
        part
      }
      val descriptor = Cat(parts)
      val position = keptApart(Reg(Position()))
      when(copyIdle) {
        position.x := item.x
        position.y := item.y
      }
    }
    val liveCopies = Seq.fill((P + MatcherConfig.lanesPerLiveCopy - 1) / MatcherConfig.lanesPerLiveCopy)(new LiveCopy)
    def liveCopy(l: Int): LiveCopy = liveCopies(l / MatcherConfig.lanesPerLiveCopy)
    val results =
      for ((r, l) <- reads.zipWithIndex) yield new Area {
        val liveDescriptor = liveCopy(l).descriptor
        val popcount = new MatcherConfig.Hamming(r.entry.descriptor, liveDescriptor, m)
        val count = popcount.distance
        val index = (group.resize(countWidth) |<< log2Up(P)) | U(l, countWidth bits)
        val real = reals(l)
        // the entry's best so far compared with the popcount's last sum, a clock before the count, as its cross word
        // comes out of the RAM's register: the lane's write enable waits for no comparison
        val wins = valid && real && popcount.below(r.crossRead.distance)
        // A live feature nearer than the entry's best so far takes the entry over (mutual decided when its scan ends).
        val update = Cross(); update.distance := count; update.mutual := False
        update.liveX := liveCopy(l).position.x
        update.liveY := liveCopy(l).position.y
        val out = Lane()
        out.distance := Mux(real, count, U(none, distanceWidth bits))
        out.index := index
        out.wins := wins
        val writeUpdate = wins
      }
    case class Best() extends Bundle { val best = Lane(); val second = UInt(distanceWidth bits) }
    def single(l: Lane): Best = { val b = Best(); b.best := l; b.second := none; b }

    /** The merge of two bests: the best of the two (the left, earlier entries, on ties) and the second smallest
      * distance of the union. As a best is never above its second, the second is the smaller of the loser and the
      * winner's own second: its three comparisons are side by side, none waits for another, and are registered
      * (`compared`) before `select` chooses by them a clock later. */
    case class Comparisons() extends Bundle { val takeB, bSecondFirst, aSecondFirst = Bool() }
    def compared(a: Best, b: Best): Comparisons = {
      val c = Comparisons()
      c.takeB := takes(a, b)
      c.bSecondFirst := b.second < a.best.distance
      c.aSecondFirst := a.second < b.best.distance
      RegNext(c)
    }
    def select(a: Best, b: Best, c: Comparisons): Best = {
      val r = Best()
      r.best := Mux(c.takeB, b.best, a.best)
      r.second := Mux(
        c.takeB,
        Mux(c.bSecondFirst, b.second, a.best.distance),
        Mux(c.aSecondFirst, a.second, b.best.distance)
      )
      r
    }
    def takes(a: Best, b: Best): Bool = b.best.distance < a.best.distance
    // The lanes' results registered, then every level of the merge tree in two steps: its three comparisons
    // registered with its halves, its choice a clock later (as the pairs' below). The keyframe positions are not
    // carried: the best entry's is read back when the scan is over (`lookup`).
    val outValid = RegNext(valid) init False
    val outGroup = RegNext(group)
    var level: Seq[Best] = results.map(r => RegNext(single(r.out)))
    while (level.size > 1) level = level.grouped(2).map { g =>
      val (a, b) = (g(0), g(1))
      RegNext(select(RegNext(a), RegNext(b), compared(a, b)))
    }.toSeq
    val merged = level.head
    val mergeLevels = 2 * log2Up(P)
    val mergedValid = Delay(outValid, mergeLevels, init = False)
    val mergedGroup = Delay(outGroup, mergeLevels)
    // Consecutive groups merged in pairs (an even group, registered, with the odd one after it): the running best
    // then takes a pair every other clock, in two steps, its comparisons registered before its choice, so that no
    // comparison and choice of its own loop share a clock.
    val odd = mergedGroup.lsb
    // a scan's groups come back to back: the odd group comes the clock after the even one
    val held = RegNext(merged)
    // The pair's three comparisons registered with its halves, its choice a clock later (as the running best's):
    // no choice waits for a comparison in the same clock.
    val pairing = new Area {
      val a = RegNext(held)
      val b = RegNext(merged)
      val c = compared(held, merged)
      val valid = RegNext(mergedValid && odd) init False
      val last = RegNext(mergedValid && mergedGroup === groupsCompared.lessOne) init False
    }
    val pairValid = RegNext(pairing.valid) init False
    val pairLast = RegNext(pairing.last) init False
    val pair = RegNext(select(pairing.a, pairing.b, pairing.c))
    // The running best starts as "none" when a scan starts (long before its first pair arrives): the first pair
    // then takes it over in the same merge as every later one (its entry 0 is real), no choice of the first.
    val acc = Reg(Best())
    // a clock after the start, from a register (no handshake decides the running best's enables); the last scan's
    // result has been pushed by then
    when(RegNext(scan.start) init False) {
      acc.best.distance := none
      acc.best.index := 0
      acc.best.wins := False
      acc.second := none
    }
    val choose = new Area {
      val valid = RegNext(pairValid) init False
      val last = RegNext(pairValid && pairLast) init False
      val candidate = RegNext(pair)
      val c = compared(acc, pair)
    }
    when(choose.valid) {
      acc := select(acc, choose.candidate, choose.c)
    }
    val lastGroup = RegNext(choose.last) init False
  }

  // The best entry's keyframe position, read back when the scan is over (the positions are not carried beside the
  // distances): its group into the scan's address a clock after the last accumulation (the scan reads nothing more
  // and the next one starts after the decision), its lane's word into the lane's register `crossLatency` clocks
  // later, as the sweep's (`swept`).
  val lookup = new Area {
    val bestLane = compare.acc.best.index.resize(log2Up(P) max 1)
    when(compare.lastGroup) {
      scan.group := groupOf(compare.acc.best.index, groupWidth + 1)
    }
    val reading = RegNext(compare.lastGroup) init False
  }

  // A feature's scan is over when its last group has been accumulated: accept or not, then the next feature.
  val decide = new Area {
    // When the best entry's position has been read back (`lookup`); the ratio's product is registered twice by then
    // (the multiplier's own output register, then a plain one beside the comparison).
    val done = Delay(compare.lastGroup, decideLatency, init = False)
    val emptyDone = scan.busy && groupsCompared.zero // an empty store: nothing to scan
    val a = compare.acc
    val p = frame.params
    val ratioSecond = RegNext(RegNext((p.ratio * a.second).resize(distanceWidth + m.ratioFracBits + 1)))
    // everything decided early, in registers: the best is final from `decideLatency` clocks before `done`, the
    // ratio's product two clocks later; the best distance copied beside the ratio's comparison (the running best lies
    // with the merge), which is registered too, so no carry chain lies before the decision
    val bestDistance = RegNext(a.best.distance)
    val ratioLess = RegNext(
      (bestDistance << m.ratioFracBits).resize(distanceWidth + m.ratioFracBits + 1) < ratioSecond
    ) init False
    val ratioOk = !p.ratioTest || ratioLess
    val withinThreshold = RegNext(a.best.distance <= p.hammingThreshold) init False
    val accepted = done && withinThreshold && ratioOk
    endsOn(done || emptyDone)
    // The decision registered: the mark's write and the correspondence's push leave a clock later (the next
    // feature's scan reads nothing for several clocks, and the live position stays until it starts).
    val bestLane = a.best.index.resize(log2Up(P) max 1)

    /** per lane: its entry is marked (the lane and the take-over decided a clock ahead, beside the best, as the
      * threshold is; only the ratio and `done` after those registers) */
    val markLanes = (0 until P).map { l =>
      val marks = RegNext(p.crossCheck && a.best.wins && laneIs(bestLane, l))
      RegNext(done && withinThreshold && ratioOk && marks) init False
    }
    val emit = RegNext(accepted && !p.crossCheck) init False
    val markAddr = RegNext(groupOf(a.best.index, groupWidth))
    val markValue = Cross()
    markValue.distance := bestDistance
    markValue.mutual := True
    markValue.liveX := scan.live.x
    markValue.liveY := scan.live.y
  }

  // Sweep results: each lane's cross word and position, zero unless the sweep read that lane, registered in the
  // lane `crossLatency` clocks after the read (a lane flag delayed beside the read: no lane number reaches the
  // lanes' data), then ORed into the correspondence's registers (the lanes lie apart: no selection where they meet).
  // The scan's best entry's position (`lookup`) comes the same way.
  val swept = new Area {
    val addr = Delay(sweep.addr, crossLatency)
    val lanes =
      for ((r, l) <- reads.zipWithIndex) yield new Area {
        // the flags delayed to the clock before each use, then a register (kept apart) per use, beside what it
        // selects: the cross word (and the mark), the clear's write, the position (no one flag drives them all). The
        // position comes with the entry, a clock before the cross word: picked a clock earlier (the merged position
        // waits a clock instead: one register, not one per lane)
        val sweptEarly = Delay(sweep.reading && laneIs(sweep.lane, l), crossLatency - 2, init = False)
        val lookedEarly = Delay(lookup.reading && laneIs(lookup.bestLane, l), crossLatency - 2, init = False)
        val hereBefore = RegNext(sweptEarly) init False
        val here = keptApart(RegNext(hereBefore) init False)
        val clearHere = keptApart(RegNext(hereBefore) init False)
        val keyPicked = keptApart(RegNext(sweptEarly || lookedEarly) init False)
        val emit = RegNext(here && r.cross.mutual && frame.params.crossCheck) init False
        val cross = RegNext(Mux(here, r.cross, r.cross.getZero))
        val keyX = RegNext(Mux(keyPicked, r.entry.x, U(0, cw bits)))
        val keyY = RegNext(Mux(keyPicked, r.entry.y, U(0, cw bits)))
      }
    val cross = Cross()
    cross.assignFromBits(lanes.map(_.cross.asBits).reduce(_ | _))

    /** the position read (the scan's best entry's at its decision), a clock behind the lanes' registers, as the
      * cross word */
    val key = Position()
    key.x := RegNext(lanes.map(_.keyX).reduce(_ | _))
    key.y := RegNext(lanes.map(_.keyY).reduce(_ | _))
    val out = new Area {
      val emit = RegNext(lanes.map(_.emit).orR) init False
      val liveX = RegNext(cross.liveX)
      val liveY = RegNext(cross.liveY)
      val keyX = RegNext(key.x)
      val keyY = RegNext(key.y)
      val distance = RegNext(cross.distance)
    }
  }

  // One write port per lane RAM: keyframe load, scan take-over, mutual mark, sweep clear (never two at once). The
  // writes are registered on their way to the RAMs (address, data and enable), so no decision reaches a RAM in the
  // clock it is made; nothing reads a word in the clock after it is decided (the rescan starts a clock late).
  val writePorts =
    for ((lane, l) <- lanes.zipWithIndex) yield new Area {
      val loadHere = load.writes(l)
      // the address and the write enable registered per part (`StorePart`: kept apart, so no one address register
      // drives every RAM of the store, and the enable is not merged with its twin, the rank word's decision below,
      // which drives the cross state's selection apart). The data are the live registers, the lane's copy of the
      // descriptor: they copy the input every clock of a keyframe (no scan runs then), and the input holds a
      // feature for a clock after its take, so a clock after the take (an append's write) and two clocks after (a
      // replacement's) they hold the feature taken
      val liveEntry = Entry()
      liveEntry.x := compare.liveCopy(l).position.x
      liveEntry.y := compare.liveCopy(l).position.y
      liveEntry.descriptor := compare.liveCopy(l).descriptor
      val liveBits = liveEntry.asBits.resize(MatcherConfig.storeParts * partWidth)
      for ((part, i) <- lane.store.zipWithIndex) {
        part.write(load.addr, liveBits(i * partWidth, partWidth bits), loadHere)
      }
      // the rank word a clock later than the entry, its decision registered before the selection below (the rescan
      // that reads it starts later still)
      val rankHere = keptApart(RegNext(loadHere) init False)
      // a copy of it for the data (kept apart): one register would select the address, the enable and the 32 bits of
      // data, which lie beside the lane's RAM, far from the load's decision
      val rankHereData = keptApart(RegNext(loadHere) init False)
      val rankAddr = RegNext(load.addr)
      val rankWord = Cross()
      rankWord.assignFromBits(RegNext(item.rank).asBits.resize(rankWord.getBitsWidth))
      val c = compare.results(l)
      val markHere = decide.markLanes(l)
      // the lane a clear is for, decided with the read and delayed beside it (no lane comparison on the way)
      val clearHere = swept.lanes(l).clearHere
      val address = Mux(
        rankHere,
        rankAddr,
        Mux(
          markHere,
          decide.markAddr,
          Mux(clearHere, swept.addr, Mux(keyEnd.clears(l), keyEnd.clearGroup, compare.group))
        )
      )
      // the clears' data (the sweep's and the key end's) from a flag of their own (kept apart: one flag would select
      // the address, the enable and the 32 bits of data, which lie beside the lane's RAM), outermost in the selection,
      // so that it is the data register's synchronous reset, not a level of LUTs before it (a rank word still comes
      // first)
      val clearsData = keptApart(RegNext(swept.lanes(l).hereBefore || keyEnd.busy) init False)
      val data =
        Mux(
          clearsData && !rankHereData,
          clearedCross,
          Mux(rankHereData, rankWord, Mux(markHere, decide.markValue, c.update))
        )
      val enable = rankHere || markHere || clearHere || keyEnd.clears(l) || c.writeUpdate
      lane.cross.write(RegNext(address), RegNext(data), RegNext(enable) init False)
    }

  // Ready for the next item when nothing is busy: a register, computed from the next values of the flags it depends
  // on (the FIFO's room from its register: see `paced`), so no decision hangs on the handshake or the FIFO's
  // pointers and nothing waits for the readiness's own logic; and only for an item offered in the last clock and not
  // taken then (`waiting`: offered now, its kind registered by then).
  // A keyframe feature that meets a full store holds the next item two clocks, whether it replaces (the rescan
  // starts then) or not: no rank comparison in the readiness's logic.
  // The activity's next value is read as if nothing were taken now: the readiness in the clock after a take is
  // never used (nothing is offered then: `waiting` is low), so no take (a handshake's AND and the kind's choice of a
  // new activity) lies before the readiness's register; nor does a full store's meeting (`meetsFull`), for the same
  // reason. Idle next unless taken: idle now and no rescan starting, or an activity ending now.
  val idleUntaken = (activity === Activity.IDLE && !rescan.starting) || ending.reduce(_ || _)
  val readyNext =
    idleUntaken && !sweep.drainingNext && !load.metFull && (paced.roomForItem || paced.giveUp.getAheadValue())
  val ready = RegNext(readyNext) init True
  take := ready && waiting
  item.ready := take
  waiting := item.valid && !take
  for (h <- takes.all) {
    h.ready := readyNext
    h.waiting := item.valid && !take
  }

  // The correspondence registered on its way into the FIFO (the lanes' RAMs are far from it): a scan's is pushed a
  // clock after its decision, the sweep's `pushLatency` clocks after its read.
  val beat = CorrespondenceHw(f)
  val sweptOut = swept.out
  beat.liveX := Mux(sweptOut.emit, sweptOut.liveX, scan.live.x)
  beat.liveY := Mux(sweptOut.emit, sweptOut.liveY, scan.live.y)
  // the scan's key position and the sweep's come the same way
  beat.keyX := sweptOut.keyX
  beat.keyY := sweptOut.keyY
  beat.distance := Mux(sweptOut.emit, sweptOut.distance, compare.acc.best.distance)
  // A scan's decision never meets the sweep's last correspondence: the next item is taken `crossLatency + 2` clocks
  // after the sweep's last read at the earliest, and its scan reads the RAMs before it decides.
  require(pushLatency - 1 < crossLatency + 2 + readLatency, "a sweep's correspondence would meet a scan's")
  val push = output.io.push
  push.valid := RegNext(decide.emit || sweptOut.emit) init False
  push.payload := RegNext(beat)
  // the consumer's readiness into a register before it reaches the FIFO's pointers (a skid buffer, which holds one
  // correspondence more): the consumer lies apart
  io.correspondences << output.io.pop.s2mPipe()

  // each count a clock late (`Pipes.lateCounter`): no handshake reaches a counter's enables
  val counters = new Area {
    io.status.stored := stored.resized
    io.status.storeOverflow := Pipes.lateCounter(f, load.overflow)
    io.status.matches := Pipes.lateCounter(f, push.fire)
    io.status.matchDrops := Pipes.lateCounter(f, push.valid && !push.ready)
  }
}
