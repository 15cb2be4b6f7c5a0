package orb.model

import orb.{CornerParams, OrbConfig}

/** The whole core end to end (`orb.OrbTop`): pixels -> features (`CoreModel`) -> store and matcher (`MatcherModel`). */
object SystemModel {
  final case class Result(core: CoreResult, matches: MatcherModel.Run) {
    def correspondences: Seq[Correspondence] = matches.correspondences
  }

  def run(cfg: OrbConfig, beats: Seq[Beat], corners: CornerParams, p: MatchParams): Result = {
    val core = CoreModel.run(cfg, beats, corners)
    Result(core, MatcherModel.run(core.featureStream, p, cfg.matcher))
  }

  /** The camera stream for one keyframe and one live image: the core learns a geometry from a frame before it
    * processes the next, so each image is preceded by a uniform frame of its size (no corners, so nothing to match);
    * when the sizes differ, the live size's uniform frame is sent twice (the first is a counted bad frame, the
    * second teaches the new geometry). The processed frames are then exactly the keyframe and the live image. */
  def pairBeats(key: GrayImage, live: GrayImage): Seq[Beat] = {
    def uniform(img: GrayImage) = Beat.frame(GrayImage.tabulate(img.width, img.height)((_, _) => 128))
    val sameSize = key.width == live.width && key.height == live.height
    uniform(key) ++ Beat.frame(key, keyframe = true) ++
      (if (sameSize) Nil else uniform(live) ++ uniform(live)) ++ Beat.frame(live)
  }

  /** The features of the last keyframe and of the last live frame of a run. */
  def keyAndLive(r: MatcherModel.Run): (Seq[Feature], Seq[Feature]) =
    (r.frames.filter(_.keyframe).lastOption.map(_.features).getOrElse(Nil),
      r.frames.filterNot(_.keyframe).lastOption.map(_.features).getOrElse(Nil))
}
