package ielas

import java.awt.image.BufferedImage
import java.nio.charset.StandardCharsets
import java.nio.file.{Files, Path, Paths}
import javax.imageio.ImageIO

/** An 8-bit grey image, row-major. */
case class GrayImage(width: Int, height: Int, pixels: Array[Byte]) {
  require(pixels.length == width * height, s"image: ${pixels.length} pixels for ${width}x$height")
  def apply(x: Int, y: Int): Int = pixels(y * width + x) & 0xff

  def crop(x0: Int, y0: Int, w: Int, h: Int): GrayImage = {
    require(x0 >= 0 && y0 >= 0 && x0 + w <= width && y0 + h <= height, s"crop ($x0,$y0) ${w}x$h outside ${width}x$height")
    GrayImage(w, h, Array.tabulate(w * h)(i => pixels((y0 + i / w) * width + x0 + i % w)))
  }

  def writePgm(path: Path): Path = {
    Option(path.getParent).foreach(Files.createDirectories(_))
    Files.write(path, s"P5\n$width $height\n255\n".getBytes(StandardCharsets.US_ASCII) ++ pixels)
    path
  }
}

/** Image input for tests and the simulation programs: PNG/PGM reading, test-time crops of the shared data, seeded
  * synthetic images. Real images are never committed (../shared/data is read at test time).
  */
object TestImages {
  /** The shared data directory (override with -Dielas.data=DIR). */
  def dataDir: Path = Paths.get(sys.props.getOrElse("ielas.data", "../shared/data"))

  /** Reads an 8-bit image; colour is converted as OpenCV COLOR_BGR2GRAY does (fixed point, 15-bit weights, checked against OpenCV 4.6). */
  def read(path: Path): GrayImage = {
    if (!Files.isReadable(path)) throw new IllegalArgumentException(s"image: cannot read $path")
    if (path.toString.toLowerCase.endsWith(".pgm")) return readPgm(path)
    val img = Option(ImageIO.read(path.toFile)).getOrElse(throw new IllegalArgumentException(s"image: $path is not a PNG/PGM"))
    val (w, h) = (img.getWidth, img.getHeight)
    val raster = img.getRaster
    val bits = img.getColorModel.getComponentSize(0)
    val out = new Array[Byte](w * h)
    if (img.getType == BufferedImage.TYPE_BYTE_GRAY) {
      for (y <- 0 until h; x <- 0 until w) out(y * w + x) = raster.getSample(x, y, 0).toByte
    } else if (img.getType == BufferedImage.TYPE_CUSTOM && raster.getNumBands <= 2 && bits > 8) {
      throw new IllegalArgumentException(s"image: $path is deeper than 8 bits")
    } else if (raster.getNumBands >= 3 && img.getType != BufferedImage.TYPE_BYTE_INDEXED) {
      if (bits > 8) throw new IllegalArgumentException(s"image: $path is deeper than 8 bits")
      for (y <- 0 until h; x <- 0 until w) {
        val (r, g, b) = (raster.getSample(x, y, 0), raster.getSample(x, y, 1), raster.getSample(x, y, 2))
        out(y * w + x) = ((b * 3735 + g * 19235 + r * 9798 + 16384) >> 15).toByte
      }
    } else {
      // palette or other layouts: through sRGB, then the same weights
      for (y <- 0 until h; x <- 0 until w) {
        val rgb = img.getRGB(x, y)
        val (r, g, b) = ((rgb >> 16) & 0xff, (rgb >> 8) & 0xff, rgb & 0xff)
        out(y * w + x) = ((b * 3735 + g * 19235 + r * 9798 + 16384) >> 15).toByte
      }
    }
    GrayImage(w, h, out)
  }

  def readPgm(path: Path): GrayImage = {
    val bytes = Files.readAllBytes(path)
    var i = 0
    def token(): String = {
      while (i < bytes.length && (bytes(i).toChar.isWhitespace || bytes(i) == '#')) {
        if (bytes(i) == '#') while (i < bytes.length && bytes(i) != '\n') i += 1 else i += 1
      }
      val s = i; while (i < bytes.length && !bytes(i).toChar.isWhitespace) i += 1
      new String(bytes, s, i - s, StandardCharsets.US_ASCII)
    }
    if (token() != "P5") throw new IllegalArgumentException(s"image: $path is not a binary PGM (P5)")
    val (w, h, maxVal) = (token().toInt, token().toInt, token().toInt)
    if (maxVal > 255) throw new IllegalArgumentException(s"image: $path is deeper than 8 bits")
    i += 1
    GrayImage(w, h, bytes.slice(i, i + w * h))
  }

  /** A left/right pair from the shared data, relative to [[dataDir]]. */
  def pair(left: String, right: String): (GrayImage, GrayImage) = (read(dataDir.resolve(left)), read(dataDir.resolve(right)))

  def kitti2012: (GrayImage, GrayImage) = pair("kitti2012/training/image_0/000070_10.png", "kitti2012/training/image_1/000070_10.png")
  def middleburyTsukuba: (GrayImage, GrayImage) = pair("middlebury/tsukuba/im2.png", "middlebury/tsukuba/im6.png")
  def middleburyCones: (GrayImage, GrayImage) = pair("middlebury/cones/im2.png", "middlebury/cones/im6.png")

  def flat(w: Int, h: Int, value: Int): GrayImage = GrayImage(w, h, Array.fill(w * h)(value.toByte))
  def noise(w: Int, h: Int, rnd: scala.util.Random): GrayImage = GrayImage(w, h, Array.fill(w * h)(rnd.nextInt(256).toByte))
  /** Only 0 and 255: every gradient saturates somewhere. */
  def saturated(w: Int, h: Int, rnd: scala.util.Random): GrayImage =
    GrayImage(w, h, Array.fill(w * h)((if (rnd.nextBoolean()) 255 else 0).toByte))
  /** Smooth random blobs: small gradients, the regime of real images. */
  def smooth(w: Int, h: Int, rnd: scala.util.Random): GrayImage = {
    val (a, b, c) = (rnd.nextInt(40) + 1, rnd.nextInt(40) + 1, rnd.nextInt(256))
    GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      (c + 60 * math.sin(x.toDouble / a) + 60 * math.cos(y.toDouble / b)).round.toInt.max(0).min(255).toByte
    })
  }
}
