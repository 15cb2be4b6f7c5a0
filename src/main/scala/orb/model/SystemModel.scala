package orb.model

import orb.{CornerParams, OrbConfig}

/** The whole core end to end (`orb.OrbTop`): pixels -> features (`CoreModel`) -> store and matcher (`MatcherModel`). */
object SystemModel {
  final case class Result(core: CoreResult, matches: MatcherModel.Run) {
    def correspondences: Seq[Correspondence] = matches.correspondences

    /** the correspondences of the last live frame (`pairBeats`: the one that counts) */
    def lastLive: Seq[Correspondence] =
      matches.frames.filterNot(_.keyframe).lastOption.map(_.correspondences).getOrElse(Nil)
  }

  def run(cfg: OrbConfig, beats: Seq[Beat], corners: CornerParams, p: MatchParams): Result = {
    val core = CoreModel.run(cfg, beats, corners)
    Result(core, MatcherModel.run(core.featureStream, p, cfg.matcher))
  }

  /** The camera stream for one keyframe and one live image, as a camera would give them: the core learns a
    * geometry from a frame before it processes the next, and the feature budget takes its cut from the frame before
    * (`BudgetModel`), so each image is sent once more before the frame that counts: the key image (teaches the
    * geometry), the key image (its cut), the key image as keyframe, the live image (its cut; matched too), the live
    * image. When the sizes differ the first live image is a counted bad frame and one more teaches its geometry.
    * The correspondences that count are the last frame's (`Result.lastLive`). */
  def pairBeats(key: GrayImage, live: GrayImage): Seq[Beat] = pairFrames(key, live).flatMap { case (img, k) =>
    Beat.frame(img, keyframe = k)
  }

  def pairFrames(key: GrayImage, live: GrayImage): Seq[(GrayImage, Boolean)] = {
    val sameSize = key.width == live.width && key.height == live.height
    Seq(key -> false, key -> false, key -> true) ++ (if (sameSize) Nil else Seq(live -> false, live -> false)) ++ Seq(
      live -> false,
      live -> false
    )
  }

  /** What `pairBeats` sends, for a summary. */
  def pairDescription(key: GrayImage, live: GrayImage): String =
    if (key.width == live.width && key.height == live.height)
      "5 frames: key (teaches the geometry), key (the feature budget's cut), key as keyframe, live (its cut; matched too), live (the result)"
    else
      "7 frames: key (teaches the geometry), key (the budget's cut), key as keyframe, live (a counted bad frame: another size), " +
        "live (teaches the geometry), live (its cut: the keyframe's; matched too), live (the result)"

  /** The features of the last keyframe and of the last live frame of a run. */
  def keyAndLive(r: MatcherModel.Run): (Seq[Feature], Seq[Feature]) =
    (
      r.frames.filter(_.keyframe).lastOption.map(_.features).getOrElse(Nil),
      r.frames.filterNot(_.keyframe).lastOption.map(_.features).getOrElse(Nil)
    )
}
