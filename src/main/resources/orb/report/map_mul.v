// orb.Report: a $mul becomes the number of 18x18 blocks it takes (9x9 when both operands fit), for counting only.
(* techmap_celltype = "$mul" *)
module _orb_mul (A, B, Y);
  parameter A_SIGNED = 0; parameter B_SIGNED = 0;
  parameter A_WIDTH = 1; parameter B_WIDTH = 1; parameter Y_WIDTH = 1;
  input [A_WIDTH-1:0] A; input [B_WIDTH-1:0] B; output [Y_WIDTH-1:0] Y;
  localparam N = ((A_WIDTH + 17) / 18) * ((B_WIDTH + 17) / 18);
  // The product itself is not modelled (only counted): Y comes from the first block, so that a register behind it
  // can be told apart (the block's output register).
  genvar i;
  generate
    if (A_WIDTH <= 9 && B_WIDTH <= 9) begin: half
      ORB_MUL9 #(.A_WIDTH(A_WIDTH), .B_WIDTH(B_WIDTH), .Y_WIDTH(Y_WIDTH)) m (.a(A), .b(B), .y(Y));
    end else begin: full
      ORB_MUL18 #(.A_WIDTH(A_WIDTH), .B_WIDTH(B_WIDTH), .Y_WIDTH(Y_WIDTH)) m0 (.a(A), .b(B), .y(Y));
      for (i = 1; i < N; i = i + 1) begin: blk
        ORB_MUL18 #(.A_WIDTH(A_WIDTH), .B_WIDTH(B_WIDTH)) m (.a(A), .b(B));
      end
    end
  endgenerate
endmodule
