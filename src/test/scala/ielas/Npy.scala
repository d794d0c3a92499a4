package ielas

import java.nio.{ByteBuffer, ByteOrder}
import java.nio.charset.StandardCharsets
import java.nio.file.{Files, Path}

/** A NumPy .npy (version 1.0) array: little-endian, C order (docs/interfaces.md §3). Values are kept as raw bytes. */
case class NpyArray(dtype: String, shape: Seq[Int], raw: Array[Byte]) {
  val itemBytes: Int = NpyArray.itemBytes(dtype)
  val count: Long = shape.map(_.toLong).product
  require(raw.length.toLong == count * itemBytes, s"npy: ${raw.length} data bytes do not fit shape $shape of $dtype")

  /** Value at flat index i, sign-extended for signed types. */
  def apply(i: Long): Int = {
    val o = (i * itemBytes).toInt
    dtype match {
      case "|u1" => raw(o) & 0xff
      case "<i2" => (raw(o) & 0xff) | (raw(o + 1) << 8)
      case "<u2" => (raw(o) & 0xff) | ((raw(o + 1) & 0xff) << 8)
      case "<i4" => ByteBuffer.wrap(raw, o, 4).order(ByteOrder.LITTLE_ENDIAN).getInt
    }
  }

  /** Flat index of a full index (rows first). */
  def index(idx: Int*): Long = {
    require(idx.length == shape.length, s"npy: index $idx does not match shape $shape")
    idx.zip(shape).foldLeft(0L) { case (acc, (i, n)) => acc * n + i }
  }
}

object NpyArray {
  def itemBytes(dtype: String): Int = dtype match {
    case "|u1" => 1
    case "<i2" | "<u2" => 2
    case "<i4" => 4
    case other => throw new IllegalArgumentException(s"npy: unsupported dtype '$other' (legal: |u1, <i2, <u2, <i4)")
  }

  private val magic = Array[Byte](0x93.toByte, 'N', 'U', 'M', 'P', 'Y', 1, 0)

  def read(path: Path): NpyArray = {
    val bytes = Files.readAllBytes(path)
    def fail(msg: String) = throw new IllegalArgumentException(s"npy: $path: $msg")
    if (bytes.length < 10 || !bytes.take(6).sameElements(magic.take(6))) fail("not a .npy file")
    if (bytes(6) != 1) fail(s"version ${bytes(6)} (only 1.0 is read)")
    val headerLen = (bytes(8) & 0xff) | ((bytes(9) & 0xff) << 8)
    val header = new String(bytes, 10, headerLen, StandardCharsets.ISO_8859_1)
    val descr = """'descr':\s*'([^']+)'""".r.findFirstMatchIn(header).map(_.group(1)).getOrElse(fail("no descr"))
    if (!header.contains("'fortran_order': False")) fail("only C order is read")
    val shapeText = """'shape':\s*\(([^)]*)\)""".r.findFirstMatchIn(header).map(_.group(1)).getOrElse(fail("no shape"))
    val shape = shapeText.split(",").map(_.trim).filter(_.nonEmpty).map(_.toInt).toSeq
    NpyArray(descr, shape, bytes.drop(10 + headerLen))
  }

  def write(path: Path, dtype: String, shape: Seq[Int], raw: Array[Byte]): Unit = {
    val arr = NpyArray(dtype, shape, raw) // validates
    val shapeText = if (shape.length == 1) s"(${shape.head},)" else shape.mkString("(", ", ", ")")
    val dict = s"{'descr': '${arr.dtype}', 'fortran_order': False, 'shape': $shapeText, }"
    val padded = dict + " " * ((64 - (10 + dict.length + 1) % 64) % 64) + "\n" // data aligned to 64 bytes
    val header = padded.getBytes(StandardCharsets.ISO_8859_1)
    Option(path.getParent).foreach(Files.createDirectories(_))
    val out = new java.io.ByteArrayOutputStream()
    out.write(magic)
    out.write(header.length & 0xff); out.write(header.length >> 8)
    out.write(header)
    out.write(raw)
    Files.write(path, out.toByteArray)
  }
}
