"""Animation out: glTF and USD files a renderer loads, and a page to watch them."""
