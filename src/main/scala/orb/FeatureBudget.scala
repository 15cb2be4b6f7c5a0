package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.keptApart

/** The feature budget between the corner detector and the orientation unit: which corners become features
  * (`BudgetConfig` states the rule, `orb.model.BudgetModel` is its specification).
  *
  * Cells: the corners of a band of `cellHeight` rows go into one of two banks (bands alternate), one list per cell
  * of its `perCell` strongest so far (`BudgetModel.rank`; the first in raster order on ties), kept in arrival order;
  * a corner that does not make its cell's list, or that one pushes out, is deselected at once. When the first pixel
  * of row (band end + `emitRowOffset`) is processed, the band is complete: its lists leave, a winner every
  * `FeatureBudget.winnerClocks`, in raster order (the earliest of the lists' oldest entries), and the bank is empty
  * again long before the band two later needs it. Each winner's score level goes into the frame's histogram and is
  * checked against the cut and the frame's target; it leaves on `selected` or is deselected.
  *
  * Frame end (after the frame's corners): winners still in a bank (a fault cut their band) are counted as dropped;
  * after a good frame the histogram (a RAM word per level) is walked from the top level down, one level per clock, to
  * find the next cut, and emptied on the way.
  *
  * Frames are told apart by their ends only: no corner of a frame arrives before the previous frame's end has been
  * handled (the first corners come 22 rows into a frame). */
class FeatureBudget(cfg: OrbConfig) extends Component {
  val f = cfg.frame
  val h = cfg.harris
  val b = cfg.budget
  val io = new Bundle {
    val pixels = slave Flow (TrackedPixel(f))
    val corners = slave Flow (CornerHw(f, h))
    val frameEnds = slave Flow (FrameEndHw())
    val geometry = in(FrameGeometry(f))
    val target = in UInt (BudgetConfig.targetWidth bits)
    val selected = master Flow (CornerHw(f, h))
    val deselected = out(f.counter())
    val dropped = out(f.counter())
  }
  val cells = b.cellsPerRow(f.maxWidth)
  val k = b.perCell
  val levels = b.levels(h.scoreWidth)
  // The cut is compared from its register (`decide`) and the walk shares the histogram's ports with the winners: a
  // frame end's walk (a clock per level, a few more around it) ends before the next frame's first winner, and so
  // does the walk of a frame end that came during it and waited (`frameEnd.Firing`). The end fires at the latest as
  // the last band's emission ends (within a band's rows), and a frame's first `border` rows have no corner, even in
  // the narrowest lines that keep any.
  private val walkClocks = levels + 8
  require(
    cfg.perCellSteps.headOption.forall { case (w, _) => 2 * walkClocks < (h.border - b.cellHeight).toLong * w },
    "the frame end's walks would not end before the next frame's first winner"
  )
  val levelWidth = b.levelWidth(h.scoreWidth)
  val rankWidth = b.rankWidth(h.scoreWidth)
  val maxWinners = k * cells * ((f.maxHeight + b.cellHeight - 1) / b.cellHeight)
  val countWidth = log2Up(maxWinners + 1)

  val slotWidth = log2Up(k max 2)

  case class Entry() extends Bundle {
    val valid = Bool()
    val xOffset = UInt(b.cellShift bits)
    val yOffset = UInt(b.bandShift bits)

    /** the score's rank (`BudgetModel.rank`): what the list compares */
    val rank = UInt(rankWidth bits)

    /** where its score is (`scores`): one of the list's `k` words, each place's its own */
    val slot = UInt(slotWidth bits)
  }

  /** Corners kept per cell in this frame's line length: `OrbConfig.perCellFor`, from its steps, into a register; the
    * width registered twice first on the budget's way (it changes only between frames, and comes from the frame
    * tracker, apart from the lists), then a copy per step (kept apart: no one register drives every comparison),
    * then its comparisons with the steps (the choice among them a clock later: the count changes 22 rows before a
    * frame's first corner) */
  val perCell = new Area {
    val width = RegNext(RegNext(io.geometry.width) init 0) init 0
    val reaches = cfg.perCellSteps.map { case (from, _) =>
      RegNext(keptApart(RegNext(width) init 0) >= from) init False
    }
    val fromSteps = UInt(log2Up(k + 1) bits)
    fromSteps := 0
    for (((_, n), reached) <- cfg.perCellSteps.zip(reaches)) when(reached) { fromSteps := n }
    val now = RegNext(fromSteps) init 0

    /** `now` once more, a copy (kept apart) per `FeatureBudget.listsPerCount` lists: the lists lie across the block,
      * and the count changes only at a frame's start (the tracker's geometry), 22 rows before its first corner */
    def copyFor(list: Int): UInt = copies(list / FeatureBudget.listsPerCount)
    val copies = (0 until (2 * cells + FeatureBudget.listsPerCount - 1) / FeatureBudget.listsPerCount).map { _ =>
      keptApart(RegNext(now) init 0)
    }
  }

  /** Every list in arrival order (raster order within its cell), the newest at place 0 and the place that leaves
    * first, `k - 1`, at the end. */
  val banks = Vec.fill(2)(Vec.fill(cells)(Vec.fill(k)(Reg(Entry()))))
  for (bank <- banks; cell <- bank; (e, i) <- cell.zipWithIndex) {
    e.valid.init(False)
    e.slot.init(i)
  }

  // The scores, which only the emission's output needs, in a RAM beside the lists (a word per place of every
  // list): a place holds its word's number, which moves with the entry; a corner that enters takes the word of the
  // place it frees (an empty one, or the weakest it pushes out), so the places' words stay distinct. The bank being
  // emitted takes no corner, so a winner's word is not written until it has been read.
  val scores = new Area {
    val cellWidth = log2Up(cells max 2)
    val ram = Mem(UInt(h.scoreWidth bits), 2 << (cellWidth + slotWidth))
    def address(bank: UInt, cell: UInt, slot: UInt): UInt = bank @@ cell @@ slot
  }

  // A corner into its cell's list. Each list decides beside its own registers, and each place is loaded only from
  // the place before it (place 0 from the corner), so no list is read through a multiplexer and every place has one
  // source. The corner is ranked on the way in (three registered steps), then lined up with a copy of its rank per
  // list (kept apart), which each list compares with its places into registers, then registered with its list
  // decoded (one-hot) and one copy of it per bank. In that clock each list decides into registers from registers:
  // does the corner enter (a place in use is empty, or ranked below it), and which place would a full list give up
  // (from the places' relations, registers moved with the entries). In the clock after, the corner enters at place
  // 0 and the places up to the freed one move one place on: the first empty place of a list that is not full, else
  // the weakest (ranked lowest, the newest of those ranked lowest). Corners are at least two clocks apart after the
  // 3x3 suppression: a corner decides on its list after the one before it has updated it, and it was compared with
  // the list as it was before that update, which the list corrects by the moves it made.
  val intake = new Area {
    val cellWidth = log2Up(cells max 2)
    val lists = for (bank <- 0 until 2; cell <- 0 until cells) yield (bank, cell)

    /** the corner's rank, in three registered steps (its leading one, a shift by the position's multiple of 4, the
      * rest of the shift) */
    val ranked = new Area {
      val first = io.corners.stage()
      val lead = RegNext(Arith.leadOf(io.corners.score))
      val second = first.stage()
      val secondLead = RegNext(lead)
      val coarse = RegNext(Arith.afterLeadCoarse(first.score, lead, b.rankFracBits))
      val corner = second.stage()
      val rank = RegNext(Arith.rankFrom(coarse, secondLead, b.rankFracBits, rankWidth))
    }

    /** the corner a clock on, its rank with a copy per list (kept apart): each list compares it with its places */
    val lined = new Area {
      val valid = RegNext(ranked.corner.valid) init False
      val corner = RegNext(ranked.corner.payload)
      val rank = RegNext(ranked.rank)
      val ranks = lists.map { _ =>
        keptApart(RegNext(ranked.rank))
      }
    }
    val bankIn = lined.corner.y(b.bandShift downto b.bandShift)
    val cellIn = lined.corner.x(b.cellShift, cellWidth bits)
    val arriving = new Area {
      val valid = RegNext(lined.valid) init False

      /** the corner, one copy per bank (kept apart): each feeds place 0 of its bank's lists */
      val corners = (0 until 2).map { _ =>
        keptApart(RegNext(lined.corner))
      }

      /** its rank, one copy per bank (kept apart), as the corner */
      val ranks = (0 until 2).map { _ =>
        keptApart(RegNext(lined.rank))
      }
      val rank = RegNext(lined.rank)

      /** its list, one-hot over (bank, cell) */
      val selects =
        RegNext(Vec(lists.map { case (bank, cell) => lined.valid && bankIn === bank && cellIn === cell }))
      selects.foreach(_.init(False))
    }

    val compared = new Area {
      val valid = RegNext(arriving.valid) init False
      val corners = arriving.corners.map(RegNext(_))
      val ranks = arriving.ranks.map(RegNext(_))
      val rank = RegNext(arriving.rank)
    }

    /** the corner lined up ranked above the one entering its list now (at place 0, for the clock after) */
    val aboveEntering = RegNext(lined.rank > compared.rank)
    val perList =
      for (((bank, cell), l) <- lists.zipWithIndex) yield new Area {
        val list = banks(bank)(cell)

        /** the list places in use in this line length (it changes only between frames), registers of the list's
          * own (kept apart: one register would reach every list), from the registered count per cell */
        val inUse = (0 until k).map(i => keptApart(RegNext(U(i) < perCell.copyFor(l)) init False))

        /** the corner lined up ranked above each place as the list is then (registers) */
        val aboveStaying = RegNext(Vec((0 until k).map(i => lined.ranks(l) > list(i).rank)))

        /** which places moved in that clock (registers, set below) */
        val moved = Vec.fill(k)(Reg(Bool()) init False)

        /** the arriving corner ranked above each place: as the place was, or as the place it moved from (place 0:
          * the corner that entered) */
        val corner = (0 until k).map { i =>
          Mux(moved(i), if (i == 0) aboveEntering else aboveStaying(i - 1), aboveStaying(i))
        }

        /** the corner enters: a place in use is empty, or ranked below it (the corner is the newest: a tie keeps
          * the entry) */
        val admits = RegNext((0 until k).map(i => inUse(i) && (!list(i).valid || corner(i))).orR) init False

        /** the comparisons, registered: the relations of the entering corner to the places it meets */
        val cornerAbove = RegNext(Vec(corner))

        /** place a ranked above place b, for a newer than b (a < b): registers, not comparisons. A relation is set
          * when the newer entry enters (from `cornerAbove`) and moves with the two entries (below, with the moves); a list
          * that gives up an entry loses its relations with it. Only full lists read them, whose entries all came in
          * as corners, each compared with the older ones there. */
        val above = (for (a <- 0 until k; b <- a + 1 until k) yield (a, b) -> Reg(Bool())).toMap

        /** the place a full list gives up: every newer place ranked above it, no older one in use ranked below it */
        val weakestNext = (0 until k).map { j =>
          val newer = (0 until j).map(a => above((a, j)))
          val older = (j + 1 until k).map(b => !inUse(b) || !above((j, b)))
          (inUse(j) +: (newer ++ older)).reduce(_ && _)
        }
        val fullNext = (0 until k).map(i => !inUse(i) || list(i).valid).andR
        val full = RegNext(fullNext) init False

        /** the corner's list, one copy per place (kept apart): no one register enables a whole list. (The
          * admission is not folded into them: its logic before every copy routed worse than one register after
          * it.) */
        val writes = (0 until k).map { _ =>
          keptApart(RegNext(arriving.selects(l)) init False)
        }

        /** the list's band is being emitted (set and cleared by the emission): its entries move on whenever the
          * place that leaves first is empty */
        val emptying = keptApart(Reg(Bool()) init False)

        /** `emptying` while the last place is empty, decided a clock ahead into registers from the next value of
          * `emptying` and of the last place as it empties (`lastValidNext`): no path from the list's last place or
          * the emission to every place's enable; one copy per place (kept apart), as `writes` */
        val advances = (0 until k).map { _ =>
          keptApart(Reg(Bool()) init False)
        }
        // a list being emptied moves an empty entry into place 0
        val fresh = Entry()
        fresh.valid := !emptying

        /** the emission takes the winner from this list's last place in this clock (set by the emission) */
        val leaves = Bool()

        /** the last place's next value while the list empties (or starts to, in the trigger's clock): it changes
          * only by a move or a winner leaving. No corner enters it then: the band's own corners are in their lists
          * before its trigger (`BudgetConfig.emitRowOffset` covers the detector's latency, as the emission itself
          * needs), and the band two later, which shares the bank, gets its first corner after the emission
          * (`OrbConfig.budgetService`); nor does the frame's end fire (it waits until the emission has ended). So
          * neither is in it. */
        val lastValidNext = !leaves && Mux(
          advances(k - 1),
          if (k == 1) fresh.valid else list(k - 2).valid,
          list(k - 1).valid
        )
        val advancesNext = emptying.getAheadValue() && !lastValidNext
        advances.foreach(_ := advancesNext)
        fresh.xOffset := compared.corners(bank).x.resize(b.cellShift)
        fresh.yOffset := compared.corners(bank).y.resize(b.bandShift)
        fresh.rank := compared.ranks(bank)
        // place i moves on when the freed place is i or after it: in a list that is not full the first empty one
        // (the places before it are full), in a full one the weakest; decided with the comparisons into registers
        // (the list does not change in between: the corner before it wrote a clock earlier)
        val freedFrom = (0 until k).map { i =>
          if (i == 0) True
          else RegNext(Mux(fullNext, weakestNext.drop(i).orR, list(i - 1).valid)) init False
        }
        val moving = (0 until k).map { i =>
          (writes(i) && admits && freedFrom(i)) || advances(i)
        }
        for (i <- 0 until k) {
          moved(i) := moving(i)
        }
        // the freed place's word: the last place that moves (`freedFrom` holds up to the freed place); a list being
        // emptied moves its last place's (empty) into place 0
        val freedSlot = MuxOH.or(
          (0 until k).map(i => if (i == k - 1) freedFrom(i) else freedFrom(i) && !freedFrom(i + 1)),
          list.map(_.slot)
        )
        fresh.slot := Mux(emptying, list(k - 1).slot, freedSlot)

        /** the corner enters this list now: its score goes into the freed place's word */
        val enters = writes.head && admits
        // the relations move with the entries: a place that takes the one before it takes its relations (with the
        // place before an older place that moves too, else with that older place itself); place 0 takes the
        // corner's
        for (a <- 0 until k; b <- a + 1 until k) {
          when(moving(a)) {
            above((a, b)) := (
              if (a == 0) Mux(moving(b), cornerAbove(b - 1), cornerAbove(b))
              else Mux(moving(b), above((a - 1, b - 1)), above((a - 1, b)))
            )
          }
        }
        for (i <- 0 until k) {
          val from = if (i == 0) fresh else list(i - 1)
          when(moving(i)) {
            list(i) := from
          }
        }

        /** the corner is deselected here: its list keeps k entries, the corner itself or the weakest it pushes out */
        val deselects = writes.head && full
      }

    /** a corner deselected in this clock */
    val deselect = perList.map(_.deselects).orR

    // The entering corner's score into its word: the list and its word registered beside the list, the RAM's
    // address chosen from them into a register, the score delayed beside it (no list's logic reaches the RAM).
    val scoreWrite = new Area {
      val entered = RegNext(Vec(perList.map(_.enters)))
      entered.foreach(_.init(False))
      val slots = perList.map(l => RegNext(l.freedSlot))
      val addresses = lists.zip(slots).map { case ((bank, cell), slot) =>
        scores.address(U(bank, 1 bits), U(cell, scores.cellWidth bits), slot)
      }
      val score = Delay(compared.corners.head.score, 2)
      scores.ram.write(RegNext(MuxOH.or(entered, addresses)), score, RegNext(entered.orR) init False)
    }

    /** a corner on its way into a list */
    val busy = ranked.first.valid || ranked.second.valid || ranked.corner.valid || lined.valid || arriving.valid ||
      compared.valid
  }

  // A band is complete at the first pixel of row (band end + emitRowOffset); its winners leave in raster order.
  val emission = new Area {
    // the stream position registered on the way in (the line buffer lies apart; kept apart from the detector's
    // identical stage register), its row start and its row's tests registered apart, and whether they trigger a
    // band joined a clock ahead into a register (the trigger holds the frame end too): the band starts three clocks
    // after its row's first pixel reaches the budget (`FeatureBudget.emissionClocks`; its corners came rows before,
    // the frame's end comes after the detector's latency)
    val p = new Area {
      val valid = keptApart(RegNext(io.pixels.valid) init False)
      val x = keptApart(RegNext(io.pixels.x))
      val y = keptApart(RegNext(io.pixels.y))
      val active = keptApart(RegNext(io.pixels.active))
    }
    // a band ends every cellHeight rows: y - emitRowOffset is a multiple of it where y's low bits are the offset's
    val endsBand = p.y >= b.cellHeight + b.emitRowOffset &&
      p.y(b.bandShift - 1 downto 0) === (b.emitRowOffset % b.cellHeight)
    val rowStart = RegNext(p.valid && p.x === 0 && p.active) init False
    val rowEndsBand = RegNext(endsBand) init False
    // the row's band number counted from the emission rows (one subtraction a clock: this one, then the band's)
    val sinceEnd = RegNext((p.y - b.emitRowOffset)(f.coordWidth - 1 downto b.bandShift))
    val triggers = rowStart && rowEndsBand
    // kept apart: the frame end's copies of the same register (`Firing.triggered`) would otherwise absorb it, and
    // one of them then drive every list's moves from across the block
    val trigger = keptApart(RegNext(triggers) init False)

    /** the band that ends `emitRowOffset` rows before the triggering row */
    val band = RegNext(sinceEnd - 1)
    val busy = Reg(Bool()) init False
    // one winner every `FeatureBudget.winnerClocks`: the histogram's read-modify-write of a RAM word takes that long
    val pace = Reg(UInt(log2Up(FeatureBudget.winnerClocks) bits)) init 0
    val bank = Reg(UInt(1 bits)) init 0
    val bandY = Reg(f.coord()) init 0
    when(trigger) {
      busy := True
      bank := band(0 downto 0)
      bandY := (band @@ U(0, b.bandShift bits)).resize(f.coordWidth)
    }
    // The band's lists move their entries on towards their last place while it is empty, so each list's next in
    // raster order is at its last place (`k - 1` moves at most after the trigger, one after a winner left it). The
    // bank is empty again (every winner left) before the band two later, which shares it, gets its first corner
    // (`OrbConfig.budgetService` checks that the emission is that fast).
    // each list's emptying set by a copy of the trigger of its own (kept apart), beside the list's moves
    for (((bk, _), l) <- intake.lists.zipWithIndex) {
      val triggerHere = keptApart(RegNext(triggers) init False)
      when(triggerHere) {
        intake.perList(l).emptying := band(0 downto 0) === bk
      }
    }
    // the choice waits until every list's oldest entry is at its last place (from the clock after the
    // `settleClocks` after the trigger)
    val settling = Reg(UInt(log2Up(FeatureBudget.settleClocks(k) + 1) bits)) init 0
    when(trigger) {
      settling := FeatureBudget.settleClocks(k)
    } elsewhen (settling =/= 0) {
      settling := settling - 1
    }
    val choosing = settling =/= 0
    // the band's lists, each cell's picked from its bank by a copy of the bank register of its own (kept apart: one
    // register would choose every entry)
    def bankCopy(): UInt = {
      val copy = keptApart(Reg(UInt(1 bits)) init 0)
      when(trigger) {
        copy := band(0 downto 0)
      }
      copy
    }
    val bankOfCell = Seq.fill(cells)(bankCopy())
    val cellWidth = log2Up(cells max 2)
    case class Candidate() extends Bundle {
      val valid = Bool()

      /** the raster order within the band: row offset, cell, column offset */
      val key = UInt(b.bandShift + cellWidth + b.cellShift bits)
      val rank = UInt(rankWidth bits)
      val slot = UInt(slotWidth bits)

      /** its cell, one-hot: the list it leaves */
      val cell = Bits(cells bits)
    }

    /** the order of two heads: an empty one after every full one, then the key (keys differ: they hold the cell) */
    def order(c: Candidate): UInt = (!c.valid ## c.key).asUInt
    // Each cell's next winner (its list's last place) registered; every pair of them compared into a register; the
    // band's first, one-hot, into a register; its entry picked by it. The lists do not change while a winner is
    // chosen (they settle before the choice starts and two clocks after a winner leaves), so the comparisons and the
    // pick see the same heads.
    val heads = (0 until cells).map { cell =>
      val e = Mux(bankOfCell(cell) === 1, banks(1)(cell)(k - 1), banks(0)(cell)(k - 1))
      val cand = Candidate()
      cand.valid := e.valid
      cand.key := e.yOffset @@ U(cell, cellWidth bits) @@ e.xOffset
      cand.slot := e.slot
      cand.rank := e.rank
      cand.cell := B(BigInt(1) << cell, cells bits)
      RegNext(cand)
    }
    val before = (for (i <- 0 until cells; j <- i + 1 until cells)
      yield (i, j) -> RegNext(order(heads(i)) < order(heads(j)))).toMap
    // the one-hot twice (kept apart): one picks the key, the other the rest of the entry
    val winsNext = Vec((0 until cells).map { i =>
      (0 until cells).filter(_ != i).map(j => if (i < j) before((i, j)) else !before((j, i))).foldLeft(True)(_ && _)
    })
    val Seq(winsKey, wins) = Seq.fill(2) {
      val r = RegNext(winsNext)
      r.foreach(_.init(False))
      keptApart(r)
    }
    val picked = MuxOH.or(wins, heads)
    picked.key.allowOverride() := MuxOH.or(winsKey, heads.map(_.key))
    val first = RegNext(picked)
    // the list the winner leaves, one flag per list, registered beside the pick: with `now` the whole of a list's
    // `leaves` (no bank or cell comparison behind it; the one-hot has exactly one winner, the keys being distinct)
    val leavesList = Vec(intake.lists.map { case (bk, cell) =>
      RegNext(wins(cell) && heads(cell).valid && bank === bk) init False
    })
    require(FeatureBudget.choiceDepth == 4, "the heads, their comparisons, the one-hot and the pick")
    // A winner leaves at this step of its pace, `choiceDepth` clocks after the lists it was chosen from had settled
    // (the pace starts a clock after `choosing`; a list settles two clocks after its winner left).
    val steps = FeatureBudget.choiceDepth
    require(steps + 2 <= FeatureBudget.winnerClocks, "a list has moved on before its next winner is chosen")

    /** a winner's position (its score follows: `score`) */
    case class Winner() extends Bundle {
      val x, y = f.coord()
    }
    val out = Flow(Winner())
    // the winner's step, decided a clock ahead into a register from the next values of the registers it reads
    val nowNext = busy.getAheadValue() && pace.getAheadValue() === steps && settling.getAheadValue() === 0
    // kept apart, as its copies below are (synthesis would otherwise merge it with one of them)
    val now = keptApart(RegNext(nowNext) init False)
    keptApart(first.valid)

    /** per list: the band's emission ends now (its winner's step found no winner), from copies of `now` and of the
      * winner's valid of the list's own (kept apart): no one register clears every list's `emptying` */
    val endsForList = intake.lists.indices.map { _ =>
      val nowCopy = keptApart(RegNext(nowNext) init False)
      val validCopy = keptApart(RegNext(picked.valid) init False)
      nowCopy && !validCopy
    }
    out.valid := now && first.valid
    out.x := first.key.resize(cellWidth + b.cellShift).resize(f.coordWidth)
    out.y := bandY + first.key(first.key.getWidth - 1 downto first.key.getWidth - b.bandShift).resize(f.coordWidth)
    val outRank = first.rank

    /** the winner's score, read from its word as it leaves (the address into a register, the RAM's output
      * register): `scoreLatency` clocks after `out` */
    val score = RegNext(
      scores.ram.readSync(RegNext(scores.address(bank, OHToUInt(first.cell).resize(scores.cellWidth), first.slot)))
    )
    val scoreLatency = 3
    when(busy) {
      pace := Mux(pace === FeatureBudget.winnerClocks - 1, U(0, pace.getWidth bits), pace + 1)
    }
    when(trigger || choosing) { pace := 0 }
    for (l <- intake.lists.indices) {
      intake.perList(l).leaves := now && leavesList(l)
    }
    when(now) {
      when(first.valid) {
        for (bk <- 0 until 2; cell <- 0 until cells) {
          when(bank === bk && first.cell(cell)) {
            banks(bk)(cell)(k - 1).valid := False
          }
        }
      } otherwise {
        busy := False
      }
    }
    for (l <- intake.lists.indices) {
      when(endsForList(l)) {
        intake.perList(l).emptying := False
      }
    }
  }

  // The frame's histogram of winner levels, the cut from the last good frame, the frame's counts.
  val cut = new Area {
    val level = Reg(UInt(levelWidth bits)) init 0
    val remainder = Reg(UInt(BudgetConfig.targetWidth bits)) init 0
    val history = Reg(Bool()) init False
    val taken = Reg(UInt(BudgetConfig.targetWidth + 1 bits)) init 0
    val atCut = Reg(UInt(BudgetConfig.targetWidth + 1 bits)) init 0
  }

  // Winners per score level, in a RAM (one word per level): a winner's count is read, a register on both sides,
  // and written back incremented through a register (a clock later: winners are `FeatureBudget.winnerClocks` apart,
  // and the frame end's walk starts after the last write); the frame's end reads every level from the top and
  // writes it back as 0.
  val histogram = new Area {
    val ram = Mem(UInt(countWidth bits), levels) // emptied by the walk after reset (no initial contents needed)
    val readAddress = UInt(levelWidth bits)
    val read = Bool()
    val data = RegNext(ram.readSync(readAddress, read))
    val write = Bool()
    val writeAddress = UInt(levelWidth bits)
    val writeData = UInt(countWidth bits)
    ram.write(RegNext(writeAddress), RegNext(writeData), RegNext(write) init False)
  }

  // Winners, three clocks after they leave the bank (beside their level: the rank's leading bits, taken in three
  // registered steps), against the cut and the target. The comparisons with the counts are
  // registered a clock ahead: winners are `FeatureBudget.winnerClocks` apart, so the counts have settled long
  // before the next one.
  val decide = new Area {
    val oneLater = emission.out.stage()
    val twoLater = oneLater.stage()
    val winner = twoLater.stage()
    // the level of `levelFracBits` (`BudgetModel.level`) is the rank of `rankFracBits` without its last bits
    val levelNext = Arith.floorShift(RegNext(RegNext(emission.outRank)), b.rankFracBits - b.levelFracBits)
    val level = RegNext(levelNext).resize(levelWidth)
    // the level against the cut registered with the level (no comparison between the level and the decision), the
    // cut from its register: it changes only in a frame end's walk, which ends long before the next frame's first
    // winner (its corners come 22 rows into it), so no walk's logic before the comparison
    val aboveCut = RegNext(levelNext.resize(levelWidth) > cut.level) init False
    val atCutLevel = RegNext(levelNext.resize(levelWidth) === cut.level) init False
    val target = io.target
    val room = RegNext(cut.taken < target) init False
    val roomAtCut = RegNext(cut.atCut < cut.remainder) init False
    val inCut = !cut.history || aboveCut || (atCutLevel && roomAtCut)
    val take = winner.valid && room && inCut
    val deselect = winner.valid && !take
    // the count of the winner's level comes back two clocks later and is written back a clock after that
    val counting = Delay(winner.valid, 2, init = False)
    val inFlight = oneLater.valid || twoLater.valid || winner.valid || RegNext(winner.valid, init = False) || counting
    val countedLevel = Delay(level, 2)
    // counted a clock later, from registers (the next winner is `winnerClocks` away)
    val took = RegNext(take) init False
    val tookAtCut = RegNext(cut.history && atCutLevel) init False
    when(took) {
      cut.taken := cut.taken + 1
      when(tookAtCut) {
        cut.atCut := cut.atCut + 1
      }
    }
    io.selected.valid := RegNext(take) init False
    io.selected.x := RegNext(winner.x)
    io.selected.y := RegNext(winner.y)
    // the score read as the winner left the bank, beside it here
    require(emission.scoreLatency == 3, "the winner is three stages on")
    io.selected.score := RegNext(emission.score)
  }

  object Phase extends SpinalEnum {
    val run, scan = newElement()
  }
  // A frame's end waits until the corners before it are in their lists and a band being emitted has left
  // (the model emits every band whose emission row was processed); then what a fault left in the banks is
  // dropped, and after a good frame the histogram is walked from the top level for the next cut, emptied on the way.
  val frameEnd = new Area {
    // the detector's frame end through a register first (the detector lies apart from the copies it sets)
    val ended = io.frameEnds.stage()
    val pending = Reg(Bool()) init False
    val pendingOk = Reg(Bool()) init False
    when(ended.valid) {
      pending := True
      pendingOk := (pending && pendingOk) || ended.ok
    }
    // nothing in flight: no corner on its way into a list, no band being emitted, no winner's count unwritten
    // (a corner at the input is none of its frame's: it comes at least 22 rows into the next frame); decided a
    // clock ahead into a register from this clock's state, and what entered since (a corner in the intake's first
    // register, a band's trigger) tested beside it: no path from another block or through the trigger's logic
    val quiets = !intake.busy && !emission.busy && !emission.trigger && !decide.inFlight

    // after reset the histogram RAM may hold a cut-off frame's counts: the walk empties it first
    val phase = RegInit(Phase.scan)

    /** The frame end fires: its own copies (kept apart) of `pending`, of the quiet test, of what entered since and of
      * the walk's phase, each copy beside what it drives (the walk's state, a share of the banks), so no one flag
      * spans the block. A frame end that comes during the last one's walk (a frame cut short right after a good one)
      * waits for the walk's end: the good frame's cut is found whole, as the model finds it. */
    class Firing extends Area {
      val waiting = keptApart(Reg(Bool()) init False)
      val quiet = keptApart(RegNext(quiets) init False)
      val entering = keptApart(RegNext(io.corners.valid) init False)
      val triggered = keptApart(RegNext(emission.triggers) init False)
      val walking = keptApart(RegNext(phase.getAheadValue() === Phase.scan) init True)
      val fire = waiting && quiet && !entering && !triggered && !walking
      when(ended.valid) { waiting := True }
      when(fire) { waiting := False }
    }
    val firing = new Firing
    val fire = firing.fire
    when(fire) { pending := False }
    val good = Reg(Bool()) init False
    val issue = Reg(UInt(levelWidth bits)) init levels - 1
    val bottom = Reg(Bool()) init Bool(levels == 1)
    val need = Reg(UInt(BudgetConfig.targetWidth + 1 bits)) init 0
    val found = Reg(Bool()) init False
    // the winners left in the banks when the frame end fires, counted in registered steps (a list's count, a
    // bank's, their sum; the firing's own sum passed on, three clocks after it) and so reported four clocks later
    // (summed as wide as all the banks' entries need, not as the counter: short carry chains; the banks lie apart,
    // so their sum has a clock of its own before the choice)
    val dropWidth = log2Up(banks.size * cells * k + 1)
    val listCounts = RegNext(Vec(banks.map(bank => Vec(bank.map(list => CountOne(list.map(_.valid).toSeq))))))
    val bankCounts = RegNext(Vec(listCounts.map(_.map(_.resize(dropWidth)).reduceBalancedTree(_ + _))))
    val bankSum = RegNext(bankCounts.reduceBalancedTree(_ + _))
    val fired = Delay(fire, 3, init = False)
    val dropped = RegNext(fired ? bankSum.resize(f.counterWidth) | U(0, f.counterWidth bits))
    dropped.init(0)
    // the banks emptied by their own copies of the firing, one per `FeatureBudget.cellsPerFiring` cells of a bank
    for (bank <- banks; cells <- bank.grouped(FeatureBudget.cellsPerFiring)) {
      val copy = new Firing
      when(copy.fire) {
        for (cell <- cells; e <- cell) e.valid := False
      }
    }
    when(fire) {
      phase := Phase.scan
      good := pendingOk
      issue := levels - 1
      bottom := Bool(levels == 1)
    }
    // the walk's count of what it still needs, reset by a copy of the firing of its own (it lies beside the count)
    val needFiring = new Firing
    when(needFiring.fire) {
      need := io.target.resize(need.getWidth)
      found := False
    }
    // a level's count arrives two clocks after its read; whether the lowest level is issued (`bottom`: `issue` is
    // 0) kept in a register, decided a clock ahead (no comparison of `issue` before its own enable)
    val reading = phase === Phase.scan && !RegNext(phase === Phase.scan && bottom, init = False)
    val readLevel = issue
    val arrives = Delay(reading, 2, init = False)
    val arrivedLevel = Delay(readLevel, 2)
    when(phase === Phase.scan && !bottom) {
      issue := issue - 1
      bottom := issue === 1
    }
    // The count is registered once more beside the walk's decisions (the RAM lies apart), its level and arrival with
    // it. `need` is the target less the winners above the level being decided (until the cut is found, when it is
    // > 0; after that nothing reads it): the level holds the cut when its count reaches it, with no adder before that
    // comparison, and the comparison is registered (`reaches`) before the first level that reaches goes into the cut
    // and sets `found`: no carry chain before a decision, no decision before an adder.
    val count = RegNext(histogram.data)
    val decided = RegNext(arrives) init False
    val decidedLevel = RegNext(arrivedLevel)
    val last = decided && decidedLevel === 0
    val reaches = RegNext(decided && good && count >= need) init False
    val reachedLevel = RegNext(decidedLevel)
    val reachedNeed = RegNext(need)
    when(decided) {
      need := need - count.resize(need.getWidth)
    }
    val hit = reaches && !found
    when(reaches) {
      found := True
    }
    when(hit) {
      cut.level := reachedLevel
      cut.remainder := reachedNeed.resize(BudgetConfig.targetWidth)
    }
    // two clocks after the last level's count arrived: by then `found` holds its comparison too (no comparison waits
    // for the RAM's data here)
    val done = RegNext(RegNext(last) init False) init False
    when(done) {
      phase := Phase.run
      cut.taken := 0
      cut.atCut := 0
      when(good) {
        cut.history := True
        when(!found) {
          cut.level := 0
          cut.remainder := io.target
        }
      }
    }
  }

  // The histogram's one read port and one write port: a winner's count, or the frame end's walk.
  histogram.read := decide.winner.valid || frameEnd.reading
  histogram.readAddress := Mux(frameEnd.reading, frameEnd.readLevel, decide.level)
  histogram.write := decide.counting || frameEnd.arrives
  histogram.writeAddress := Mux(frameEnd.arrives, frameEnd.arrivedLevel, decide.countedLevel)
  histogram.writeData := Mux(frameEnd.arrives, U(0, countWidth bits), histogram.data + 1)

  val counters = new Area {
    val deselected = Reg(f.counter()) init 0
    val dropped = Reg(f.counter()) init 0
    // the clock's deselections registered where they arise, each on its own (the lists' and the cut's decisions
    // lie apart), then their sum registered, then counted
    val intakeDeselects = RegNext(intake.deselect) init False
    val cutDeselects = RegNext(decide.deselect) init False
    val deselectNow = RegNext(U(intakeDeselects).resize(2) + U(cutDeselects).resize(2)) init 0
    deselected := deselected + deselectNow.resize(f.counterWidth)
    dropped := dropped + frameEnd.dropped
  }
  io.deselected := counters.deselected
  io.dropped := counters.dropped

  /** Connects the budget behind a detector: the stream position from the line buffer's columns, the detector's
    * corners and frame ends, the tracker's geometry, the run-time target (from the parent's scope). */
  def attach(
      columns: Flow[LineColumn],
      detector: HarrisDetector,
      frameGeometry: FrameGeometry,
      frameTarget: UInt
  ): Unit = {
    io.pixels << columns.map(_.pixel)
    io.corners << detector.io.corners
    io.frameEnds << detector.io.frameEnds
    io.geometry := frameGeometry
    io.target := frameTarget
  }
}

object FeatureBudget {

  /** Clocks between two winners leaving a bank: the registered steps that choose one, and the histogram's read, its
    * registered data, the write back. */
  val winnerClocks: Int = 8

  /** Clocks the lists of a band with `places` places take to settle after its trigger: each moves its oldest entry
    * on to its last place, one place a clock. */
  def settleClocks(places: Int): Int = (places - 1) max 1

  /** Registers from the lists to the chosen winner: the heads, their comparisons, the one-hot, the pick. */
  val choiceDepth: Int = 4

  /** Clocks from the first pixel of a band's emission row reaching the budget until its emission of `winners` has
    * ended, exactly: the row's registers and the trigger, the lists settling, the pace's start, `choiceDepth` to the
    * first winner's step, a pace per winner and one for the empty choice that ends it, a clock to see it. */
  def emissionClocks(winners: Long, places: Int): Long =
    3 + settleClocks(places) + 1 + choiceDepth + winners * winnerClocks + 1

  /** lists served by one copy of the corners kept per cell */
  val listsPerCount: Int = 8

  /** cells of a bank emptied by one copy of the frame end's firing */
  val cellsPerFiring: Int = 8
}
